// From the shadow mask to tips and distances, on the host for both backends (the mask is a few
// hundred kB, the work per volume a few passes over it).
//
// 1. The shadow mask: A-scans classified as shadowed with at least 3 of their 8 neighbours so
//    too (speckle leaves lone ones); footprints: its 8-connected regions, those with fewer than
//    min_ascans A-scans, or fewer than min_ascans fully shadowed ones (every tool has metal: a
//    partly shadowing region alone is a lifted membrane), dropped; a footprint much smaller than
//    a tool's, behind its end and within its shaft's width, is a piece of that tool's shaft (in
//    the mask, no tip); of the rest the largest kMaxInstruments kept.
// 2. Axis: the principal direction of a footprint's A-scans in um. The shaft leaves the field,
//    so the tip is the end away from the footprint's A-scans on the volume's border (without
//    any, the end where the reflex lies deeper: the shaft rises towards the viewer). A wider
//    shaft cut by the border pulls it aside: the direction of the end's last 600 um is used.
// 3. Tip: the footprint's extreme along the axis is the rim of the tool's rounded end (a capsule's
//    cap: a sphere of radius r). For every r, and for the extreme between the last A-scan and the
//    next sample along the axis, the sphere whose rim is that extreme: its reflexes in front of
//    its centre give the centre's depth (the capsule's top above its axis, in px of the medium:
//    the cap's sqrt(R^2 - f^2), or where its pitched cylinder hides the cap R / cos p - f tan p,
//    R^2 = r^2 - across^2, the pitch p from the ridge of the reflexes behind the centre), and its
//    disc should match the footprint there; the r with the least spread of those depths and the
//    least disagreement of the footprint wins, and its centre is the tip. Open jaws (the
//    footprint's last 300 um in two parts): each jaw's end so, and the tip their middle.
//    A translucent end (mostly partly shadowed A-scans) is the scraper's flat paddle: the tip is
//    the middle of its leading edge on the paddle's middle plane (fitted to its reflexes),
//    back by its half thickness x sin(pitch); a paddle on or just above the retina is first
//    grown into the A-scans whose segmented ILM lies on its front surface, and joined to its
//    leading face where that was classified apart from it.
// 4. Distances: the ILM and RPE at the tip's lateral position. The tip's own A-scan is under the
//    tool; the surfaces come from measured A-scans at least 2 A-scans and 1 B-scan away from the
//    mask (the filtered volume smears the shadow's edge): a quadratic surface fitted to those
//    within 300 um of the tip where they surround it; else the nearest along the B-scan and
//    across B-scans, interpolated linearly where both sides exist (with one side only, a line
//    through its 8 nearest usable A-scans), each axis weighted by the inverse of its span
//    (inferred); or from the A-scan itself when it is clear of the mask and measured (measured).
#pragma once

#include <memory>

#include "ioct/gpu/instruments/instrument_config.hpp"
#include "ioct/gpu/instruments/instrument_findings.hpp"
#include "ioct/gpu/segmentation/surfaces.hpp"

namespace ioct::gpu::instruments {

// The steps above, with the buffers they work in kept from call to call: after the first call on
// a volume's dimensions and tools, a call allocates nothing (it runs after every group).
class TipFinder {
 public:
  TipFinder();
  ~TipFinder();
  TipFinder(TipFinder&&) noexcept;
  TipFinder& operator=(TipFinder&&) noexcept;

  // Fills findings.tips, nearest and warning from findings.columns, reflex_px and front_px (and
  // findings.mask; grows the mask onto a paddle lying on the retina, from the surfaces' ILM).
  // `surfaces` of other dimensions than the mask (or empty) give tips without distances.
  void find(InstrumentFindings& findings, const segmentation::Surfaces& surfaces,
            const InstrumentConfig& config, const VolumeSampling& sampling);

  // find() in two halves, for a caller whose surfaces come later (the live stages segment on the
  // device meanwhile): locate() does steps 1-3 from the mask alone (a scraper's paddle, which
  // grows onto the segmented ILM, and the tools after it wait), place() the rest and step 4 with
  // the surfaces. Between them the findings hold the tips without distances. The same config and
  // sampling for both; place() for findings not located last throws std::logic_error.
  void locate(InstrumentFindings& findings, const InstrumentConfig& config,
              const VolumeSampling& sampling);
  void place(InstrumentFindings& findings, const segmentation::Surfaces& surfaces,
             const InstrumentConfig& config, const VolumeSampling& sampling);

 private:
  struct Buffers;
  // The tools' axes and ends from the next one on, a paddle grown where `surfaces` are given;
  // false where a paddle waits for them.
  bool shape_tools(InstrumentFindings& findings, const segmentation::Surfaces* surfaces, double sx,
                   double sy);
  // The shaped tools' tips (no distances yet) into findings.tips.
  void tips_of_tools(InstrumentFindings& findings, const InstrumentConfig& config,
                     const VolumeSampling& sampling);

  std::unique_ptr<Buffers> buffers_;
  const InstrumentFindings* located_ = nullptr;  // by locate(), not yet placed
};

// TipFinder::find with buffers of its own (one call).
void find_tips(InstrumentFindings& findings, const segmentation::Surfaces& surfaces,
               const InstrumentConfig& config, const VolumeSampling& sampling);

}  // namespace ioct::gpu::instruments
