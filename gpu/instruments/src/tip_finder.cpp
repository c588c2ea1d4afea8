#include "ioct/gpu/instruments/tip_finder.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <vector>

namespace ioct::gpu::instruments {
namespace {

using segmentation::Surfaces;
using segmentation::SurfaceState;

// The largest end radius tried (um): a 19 G shaft's.
constexpr double kMaxRadiusUm = 550.0;
// The end's fit weighs the spread of its reflexes' centre depths (px^2) against the share of
// A-scans where its footprint disagrees with the sphere's: this much of each costs the same.
constexpr double kDepthSpreadPx2 = 4.0;
constexpr double kFootprintMismatch = 0.1;
// Surfaces are taken this many A-scans away from the shadow mask at least.
constexpr std::int64_t kSurfaceMarginAscans = 2;

// The first of kinds[from, n) that is not clear (n if none). Most of a mask is clear: eight
// A-scans are skipped at a time.
std::size_t next_not_clear(const ColumnKind* kinds, std::size_t from, std::size_t n) {
  static_assert(sizeof(ColumnKind) == 1 && static_cast<int>(ColumnKind::clear) == 0);
  while (from + 8 <= n) {
    std::uint64_t eight = 0;
    std::memcpy(&eight, kinds + from, sizeof eight);
    if (eight != 0) break;
    from += 8;
  }
  while (from < n && kinds[from] == ColumnKind::clear) ++from;
  return from;
}

// An A-scan of the mask: its index, B-scan and A-scan (kept beside the index: recovering them
// from it takes a division, dearer than the rest of the work on an A-scan).
struct Place {
  std::uint32_t k = 0, b = 0, a = 0;
};

struct Footprint {
  std::vector<Place> ascans;
};

// The 8 neighbours of an A-scan, (B-scan, A-scan) offsets in the order a footprint grows in: its
// A-scans' order follows, and the sums over a footprint add in that order.
constexpr std::array<std::array<std::int64_t, 2>, 8> kNeighbours = {
    {{-1, -1}, {-1, 0}, {-1, 1}, {0, -1}, {0, 1}, {1, -1}, {1, 0}, {1, 1}}};

bool inside_mask(const InstrumentFindings& f, std::int64_t b, std::int64_t a) {
  return b >= 0 && a >= 0 && b < f.bscans && a < f.ascans;
}

bool is_masked(ColumnKind kind) {
  return kind != ColumnKind::clear;
}

// Of its 8 neighbours, those of (b, a) classified as masked.
int masked_neighbours(const InstrumentFindings& f, std::int64_t b, std::int64_t a) {
  const std::int64_t ascans = f.ascans;
  const ColumnKind* at = &f.columns[static_cast<std::size_t>(b * ascans + a)];
  if (b > 0 && a > 0 && b + 1 < f.bscans && a + 1 < ascans) {
    const ColumnKind* above = at - ascans;
    const ColumnKind* below = at + ascans;
    return is_masked(above[-1]) + is_masked(above[0]) + is_masked(above[1]) + is_masked(at[-1]) +
           is_masked(at[1]) + is_masked(below[-1]) + is_masked(below[0]) + is_masked(below[1]);
  }
  int count = 0;
  for (const auto& [db, da] : kNeighbours) {
    if (inside_mask(f, b + db, a + da)) count += is_masked(at[db * ascans + da]) ? 1 : 0;
  }
  return count;
}

// The 8-connected region of the mask around `start`, grown depth first; its A-scans are cleared
// in `open` (the masked A-scans in no region yet) as they are reached. The stack holds (b, a) in
// one word: a store per neighbour instead of three.
Footprint region_of(const InstrumentFindings& f, Place start, ColumnKind* open,
                    std::vector<std::uint64_t>& stack) {
  Footprint fp;
  const std::int64_t ascans = f.ascans;
  const auto packed = [](std::int64_t b, std::int64_t a) {
    return static_cast<std::uint64_t>(b) << 32 | static_cast<std::uint64_t>(a);
  };
  open[start.k] = ColumnKind::clear;
  stack.resize(std::max<std::size_t>(stack.size(), 64));
  std::uint64_t* pending = stack.data();
  std::size_t capacity = stack.size();
  pending[0] = packed(start.b, start.a);
  std::size_t top = 1;
  while (top > 0) {
    const std::uint64_t ba = pending[--top];
    const auto b = static_cast<std::int64_t>(ba >> 32),
               a = static_cast<std::int64_t>(ba & 0xffffffffu);
    const std::int64_t k = b * ascans + a;
    fp.ascans.push_back({static_cast<std::uint32_t>(k), static_cast<std::uint32_t>(b),
                         static_cast<std::uint32_t>(a)});
    if (capacity < top + kNeighbours.size()) {
      stack.resize(2 * capacity);
      pending = stack.data();
      capacity = stack.size();
    }
    // Pushed always, kept where open: a branch on the mask is mispredicted too often.
    const auto visit = [&](std::int64_t db, std::int64_t da) {
      ColumnKind& n = open[k + db * ascans + da];
      const bool reached = is_masked(n);
      n = ColumnKind::clear;
      pending[top] = packed(b + db, a + da);
      top += reached ? 1 : 0;
    };
    if (b > 0 && a > 0 && b + 1 < f.bscans && a + 1 < ascans) {
      // Spelled out, in kNeighbours' order: the common case, without the border's tests.
      visit(-1, -1);
      visit(-1, 0);
      visit(-1, 1);
      visit(0, -1);
      visit(0, 1);
      visit(1, -1);
      visit(1, 0);
      visit(1, 1);
      continue;
    }
    for (const auto& [db, da] : kNeighbours) {
      if (inside_mask(f, b + db, a + da)) visit(db, da);
    }
  }
  return fp;
}

std::vector<Footprint> footprints(const InstrumentFindings& f, std::uint32_t min_ascans) {
  std::vector<ColumnKind> open = f.mask;
  std::vector<Footprint> out;
  std::vector<std::uint64_t> stack;
  for (std::uint32_t b = 0; b < f.bscans; ++b) {
    const ColumnKind* row = &open[f.index(b, 0)];
    for (std::size_t a = next_not_clear(row, 0, f.ascans); a < f.ascans;
         a = next_not_clear(row, a + 1, f.ascans)) {
      const auto start_a = static_cast<std::uint32_t>(a);
      Footprint fp = region_of(f, {static_cast<std::uint32_t>(f.index(b, start_a)), b, start_a},
                               open.data(), stack);
      // Every tool has metal (the scraper's paddle sits on a metal shaft): a footprint only
      // partly shadowed is a membrane or a floater lifted off the retina.
      const auto metal = std::count_if(fp.ascans.begin(), fp.ascans.end(), [&](const Place& p) {
        return f.mask[p.k] == ColumnKind::shadow;
      });
      if (fp.ascans.size() >= min_ascans && static_cast<std::size_t>(metal) >= min_ascans) {
        out.push_back(std::move(fp));
      }
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const Footprint& x, const Footprint& y) {
    return x.ascans.size() > y.ascans.size();
  });
  return out;
}

// A surface (ILM or RPE, px) at fractional (bscan, ascan) from the nearest unshadowed, measured
// A-scans; `source` says whether the nearest A-scan itself was usable (measured) or the surfaces
// were interpolated from its neighbours (inferred).
struct SurfaceAt {
  double ilm = InstrumentTip::kNone;
  double rpe = InstrumentTip::kNone;
  DistanceSource source = DistanceSource::none;
};

SurfaceAt surfaces_at(const InstrumentFindings& f, const Surfaces& s, double bscan, double ascan,
                      const VolumeSampling& sampling) {
  SurfaceAt out;
  if (s.bscans != f.bscans || s.ascans != f.ascans || f.size() == 0) return out;
  // Away from the mask by kSurfaceMarginAscans along the B-scan and one B-scan across: the
  // filtered volume the segmentation reads smears the shadow's edge over its neighbours.
  const auto near_mask = [&](std::int64_t b, std::int64_t a) {
    for (std::int64_t nb = std::max<std::int64_t>(0, b - 1);
         nb <= std::min<std::int64_t>(f.bscans - 1, b + 1); ++nb) {
      for (std::int64_t na = std::max<std::int64_t>(0, a - kSurfaceMarginAscans);
           na <= std::min<std::int64_t>(f.ascans - 1, a + kSurfaceMarginAscans); ++na) {
        if (f.mask[f.index(static_cast<std::uint32_t>(nb), static_cast<std::uint32_t>(na))] !=
            ColumnKind::clear) {
          return true;
        }
      }
    }
    return false;
  };
  const auto usable = [&](std::int64_t b, std::int64_t a) {
    const std::size_t k = f.index(static_cast<std::uint32_t>(b), static_cast<std::uint32_t>(a));
    return !near_mask(b, a) && s.state[k] == SurfaceState::measured && std::isfinite(s.ilm[k]) &&
           std::isfinite(s.rpe[k]);
  };
  const std::int64_t b0 = std::clamp<std::int64_t>(std::lround(bscan), 0, f.bscans - 1);
  const std::int64_t a0 = std::clamp<std::int64_t>(std::lround(ascan), 0, f.ascans - 1);
  if (usable(b0, a0)) {
    const std::size_t k = f.index(static_cast<std::uint32_t>(b0), static_cast<std::uint32_t>(a0));
    out.ilm = s.ilm[k];
    out.rpe = s.rpe[k];
    out.source = DistanceSource::measured;
    return out;
  }
  // Along each axis through the tip: the nearest usable A-scan on either side, interpolated
  // linearly where both exist; each axis weighted by the inverse of its span in um.
  double weight_sum = 0.0, ilm_sum = 0.0, rpe_sum = 0.0;
  const auto along = [&](bool across_bscans) {
    const std::int64_t n = across_bscans ? f.bscans : f.ascans;
    const double at = across_bscans ? bscan : ascan;
    const double spacing = across_bscans ? sampling.bscan_spacing_um : sampling.ascan_spacing_um;
    const auto index_of = [&](std::int64_t i) {
      return across_bscans ? f.index(static_cast<std::uint32_t>(i), static_cast<std::uint32_t>(a0))
                           : f.index(static_cast<std::uint32_t>(b0), static_cast<std::uint32_t>(i));
    };
    const auto ok = [&](std::int64_t i) { return across_bscans ? usable(i, a0) : usable(b0, i); };
    std::int64_t lo = static_cast<std::int64_t>(std::floor(at));
    // A tip fitted beyond the volume's first A-scan or B-scan has no lower side: its upper search
    // starts at the first one, never before it.
    std::int64_t hi = std::max<std::int64_t>(lo + 1, 0);
    lo = std::min(lo, n - 1);
    while (lo >= 0 && !ok(lo)) --lo;
    while (hi < n && !ok(hi)) ++hi;
    const bool has_lo = lo >= 0, has_hi = hi < n;
    if (!has_lo && !has_hi) return;
    double ilm = 0.0, rpe = 0.0, span = 0.0;
    if (has_lo && has_hi) {
      const double t = (at - static_cast<double>(lo)) / static_cast<double>(hi - lo);
      const std::size_t kl = index_of(lo), kh = index_of(hi);
      ilm = (1.0 - t) * s.ilm[kl] + t * s.ilm[kh];
      rpe = (1.0 - t) * s.rpe[kl] + t * s.rpe[kh];
      span = static_cast<double>(hi - lo) * spacing;
    } else {
      const std::int64_t i = has_lo ? lo : hi;
      ilm = s.ilm[index_of(i)];
      rpe = s.rpe[index_of(i)];
      // One-sided: an extrapolation, trusted as if the span were twice the distance.
      span = 2.0 * std::max(1.0, std::abs(at - static_cast<double>(i))) * spacing;
    }
    const double w = 1.0 / span;
    weight_sum += w;
    ilm_sum += w * ilm;
    rpe_sum += w * rpe;
  };
  along(false);
  along(true);
  if (weight_sum <= 0.0) return out;
  out.ilm = ilm_sum / weight_sum;
  out.rpe = rpe_sum / weight_sum;
  out.source = DistanceSource::inferred;
  return out;
}

// A footprint's centroid and principal axis (unit, en face, um), the axis towards the tip; an
// A-scan's place in um from the first voxel.
struct Axis {
  double sx = 1.0, sy = 1.0;
  double mx = 0.0, my = 0.0;
  double ux = 1.0, uy = 0.0;
  double x(const Place& p) const { return static_cast<double>(p.a) * sx; }
  double y(const Place& p) const { return static_cast<double>(p.b) * sy; }
  double along(const Place& p) const { return (x(p) - mx) * ux + (y(p) - my) * uy; }
  double across(const Place& p) const { return -(x(p) - mx) * uy + (y(p) - my) * ux; }
};

// Orientation: the tip away from the border the shaft crosses; else towards the deeper reflex.
bool points_to_the_shaft(const std::vector<Place>& cells, const InstrumentFindings& f,
                         const Axis& axis) {
  double border_sum = 0.0;
  std::size_t border = 0;
  double s_sum = 0.0, z_sum = 0.0, sz_sum = 0.0, ss_sum = 0.0;
  for (const Place& c : cells) {
    const double s = axis.along(c);
    if (c.a == 0 || c.b == 0 || c.a + 1 == f.ascans || c.b + 1 == f.bscans) {
      border_sum += s;
      ++border;
    }
    s_sum += s;
    z_sum += f.reflex_px[c.k];
    sz_sum += s * f.reflex_px[c.k];
    ss_sum += s * s;
  }
  const double n = static_cast<double>(cells.size());
  const double slope = (sz_sum - s_sum * z_sum / n) / std::max(1e-9, ss_sum - s_sum * s_sum / n);
  return border > 0 ? border_sum > 0.0 : slope < 0.0;
}

// In the footprint's order: the sums add its A-scans in that order.
Axis axis_of(const std::vector<Place>& cells, const InstrumentFindings& f, double sx, double sy) {
  Axis axis;
  axis.sx = sx;
  axis.sy = sy;
  for (const Place& c : cells) {
    axis.mx += axis.x(c);
    axis.my += axis.y(c);
  }
  const double n = static_cast<double>(cells.size());
  axis.mx /= n;
  axis.my /= n;
  double cxx = 0.0, cxy = 0.0, cyy = 0.0;
  for (const Place& c : cells) {
    const double dx = axis.x(c) - axis.mx;
    const double dy = axis.y(c) - axis.my;
    cxx += dx * dx;
    cxy += dx * dy;
    cyy += dy * dy;
  }
  // The principal axis of the 2 x 2 covariance.
  const double angle = 0.5 * std::atan2(2.0 * cxy, cxx - cyy);
  axis.ux = std::cos(angle);
  axis.uy = std::sin(angle);
  if (points_to_the_shaft(cells, f, axis)) {
    axis.ux = -axis.ux;
    axis.uy = -axis.uy;
  }
  return axis;
}

// The footprint's end: its A-scans within the largest radius of its extreme along the axis (all
// the fit looks at); the rim, the A-scans within one lateral sample of the extreme, and their
// offset across the axis.
struct End {
  std::vector<Place> cells;
  std::vector<double> along;  // each cell's place along the axis (um)
  double s_max = -1e300, rim = 0.0, rim_across = 0.0;
  bool translucent = false;
};

End end_of(const std::vector<Place>& cells, const InstrumentFindings& f, const Axis& axis,
           double rim) {
  End end;
  end.rim = rim;
  std::vector<double> along(cells.size());
  for (std::size_t i = 0; i < cells.size(); ++i) {
    along[i] = axis.along(cells[i]);
    end.s_max = std::max(end.s_max, along[i]);
  }
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (along[i] >= end.s_max - 2.0 * kMaxRadiusUm) {
      end.cells.push_back(cells[i]);
      end.along.push_back(along[i]);
    }
  }
  std::size_t rim_count = 0, partial = 0, shadow = 0;
  for (std::size_t i = 0; i < end.cells.size(); ++i) {
    if (end.along[i] >= end.s_max - rim) {
      end.rim_across += axis.across(end.cells[i]);
      ++rim_count;
    }
    if (end.along[i] >= end.s_max - 2.0 * rim) {
      (f.mask[end.cells[i].k] == ColumnKind::partial ? partial : shadow) += 1;
    }
  }
  end.rim_across /= static_cast<double>(rim_count);
  end.translucent = partial > shadow;
  return end;
}

// A shadowed A-scan of the end: along and across (from the rim) the axis in um, its reflex in px.
struct Reflex {
  double s, dc, z;
};

// Nearest the extreme first: a sphere sees only those in front of its centre, a prefix of this
// list that grows with its radius.
std::vector<Reflex> reflexes_of(const End& end, const InstrumentFindings& f, const Axis& axis) {
  std::vector<Reflex> reflexes;
  for (std::size_t i = 0; i < end.cells.size(); ++i) {
    const Place& c = end.cells[i];
    if (f.mask[c.k] == ColumnKind::shadow) {
      reflexes.push_back({end.along[i], axis.across(c) - end.rim_across, f.reflex_px[c.k]});
    }
  }
  std::sort(reflexes.begin(), reflexes.end(),
            [](const Reflex& x, const Reflex& y) { return x.s > y.s; });
  return reflexes;
}

// Mask rows [b_lo, b_hi], A-scans [a_lo, a_hi] of each.
struct Window {
  std::int64_t b_lo = 0, b_hi = -1, a_lo = 0, a_hi = -1;
  bool empty() const { return b_lo > b_hi || a_lo > a_hi; }
};

// A candidate end: a sphere of radius r whose rim is the footprint's extreme, its centre cs along
// the axis and (cx, cy) en face (um). Its footprint is compared out to reach, a sample further,
// over the A-scans of `window`.
struct Sphere {
  double r = 0.0, cs = 0.0, cx = 0.0, cy = 0.0, reach = 0.0;
  Window window;
};

std::vector<Sphere> spheres_of(const End& end, const Axis& axis, const InstrumentFindings& f,
                               double sx, double sy) {
  std::vector<Sphere> spheres;
  for (double r = 2.0 * end.rim; r <= kMaxRadiusUm; r += 2.0) {
    Sphere s;
    s.r = r;
    s.cs = end.s_max + 0.5 * end.rim - r;
    s.reach = r + end.rim;
    s.cx = axis.mx + s.cs * axis.ux - end.rim_across * axis.uy;
    s.cy = axis.my + s.cs * axis.uy + end.rim_across * axis.ux;
    // Wide enough: the tests decide (the casts round towards 0, hence a sample more each side).
    s.window.a_lo = std::max<std::int64_t>(0, static_cast<std::int64_t>((s.cx - s.reach) / sx) - 1);
    s.window.a_hi =
        std::min<std::int64_t>(f.ascans - 1, static_cast<std::int64_t>((s.cx + s.reach) / sx) + 1);
    s.window.b_lo = std::max<std::int64_t>(0, static_cast<std::int64_t>((s.cy - s.reach) / sy) - 1);
    s.window.b_hi =
        std::min<std::int64_t>(f.bscans - 1, static_cast<std::int64_t>((s.cy + s.reach) / sy) + 1);
    spheres.push_back(s);
  }
  return spheres;
}

// The spheres' windows together.
Window covering(const std::vector<Sphere>& spheres) {
  Window all{std::numeric_limits<std::int64_t>::max(), std::numeric_limits<std::int64_t>::min(),
             std::numeric_limits<std::int64_t>::max(), std::numeric_limits<std::int64_t>::min()};
  for (const Sphere& s : spheres) {
    if (s.window.empty()) continue;
    all.b_lo = std::min(all.b_lo, s.window.b_lo);
    all.b_hi = std::max(all.b_hi, s.window.b_hi);
    all.a_lo = std::min(all.a_lo, s.window.a_lo);
    all.a_hi = std::max(all.a_hi, s.window.a_hi);
  }
  return all.empty() ? Window{} : all;
}

// A run of A-scans of one row, [first, last]; empty where first > last.
struct Run {
  std::int64_t first = 0, last = -1;
  std::int64_t size() const { return std::max<std::int64_t>(0, last - first + 1); }
  Run operator&(const Run& other) const {
    return {std::max(first, other.first), std::min(last, other.last)};
  }
};

// The masked A-scans of any run of a row in O(1): per-row prefix counts over a window of the mask.
class MaskedRuns {
 public:
  MaskedRuns(const InstrumentFindings& f, const Window& window)
      : window_(window), stride_(window.a_hi - window.a_lo + 2) {
    if (window.empty()) return;
    prefix_.assign(static_cast<std::size_t>((window.b_hi - window.b_lo + 1) * stride_), 0);
    for (std::int64_t b = window.b_lo; b <= window.b_hi; ++b) {
      const ColumnKind* row = &f.mask[f.index(static_cast<std::uint32_t>(b), 0)];
      std::uint32_t* counts = &prefix_[static_cast<std::size_t>((b - window.b_lo) * stride_)];
      for (std::int64_t a = window.a_lo; a <= window.a_hi; ++a) {
        const std::int64_t i = a - window.a_lo;
        counts[i + 1] = counts[i] + (is_masked(row[a]) ? 1u : 0u);
      }
    }
  }

  // `run` of row b, both within the window.
  std::int64_t count(std::int64_t b, const Run& run) const {
    if (run.first > run.last) return 0;
    const std::uint32_t* counts = &prefix_[static_cast<std::size_t>((b - window_.b_lo) * stride_)];
    return static_cast<std::int64_t>(counts[run.last + 1 - window_.a_lo]) -
           static_cast<std::int64_t>(counts[run.first - window_.a_lo]);
  }

 private:
  Window window_;
  std::int64_t stride_;
  std::vector<std::uint32_t> prefix_;
};

// The first a of [lo, hi] where `holds` (hi + 1 if none), for a test that holds on from there
// along the row. Walked from `guess`: exact whatever the guess, a step or two when it is near.
template <class Test>
std::int64_t first_where(std::int64_t lo, std::int64_t hi, double guess, const Test& holds) {
  if (lo > hi) return lo;
  // Clamped first (a NaN to lo), then rounded up without a branch (lo >= 0: the cast rounds
  // down); a mispredicted branch costs more than the rest.
  const double g = std::min(std::max(static_cast<double>(lo), guess), static_cast<double>(hi + 1));
  std::int64_t a = static_cast<std::int64_t>(g);
  a += static_cast<double>(a) < g ? 1 : 0;
  while (a > lo && holds(a - 1)) --a;
  while (a <= hi && !holds(a)) ++a;
  return a;
}

// A row of the mask within reach of a sphere's centre: its A-scans [from, to], dy from the
// centre (um); mid is its first A-scan right of the centre (dx > 0).
struct DiscRow {
  std::int64_t from = 0, to = -1, mid = 0;
  double dy2 = 0.0, dy_along = 0.0;
};

// The tests of a sphere's footprint, row by row: the per-A-scan expressions of a cell-by-cell
// count. As dx rises along a row each picks out one run of it, whose ends are found by
// evaluating the test near them only (the guesses need not be exact).
class Disc {
 public:
  Disc(const Sphere& s, const Axis& axis, double sx)
      : cx_(s.cx),
        sx_(sx),
        per_sx_(1.0 / sx),
        ux_(axis.ux),
        uy_(axis.uy),
        from_(s.window.a_lo),
        to_(s.window.a_hi) {
    // dx does not depend on the row: neither does mid.
    mid_ = first_where(from_, to_, cx_ * per_sx_, [&](std::int64_t a) { return dx(a) > 0.0; });
  }

  DiscRow row(double dy) const { return {from_, to_, mid_, dy * dy, dy * uy_}; }

  // Ahead of the centre: dx * ux + dy * uy >= 0.
  Run ahead(const DiscRow& row) const {
    const auto is_ahead = [&](std::int64_t a) { return !(dx(a) * ux_ + row.dy_along < 0.0); };
    if (ux_ == 0.0) return is_ahead(row.from) ? Run{row.from, row.to} : Run{};  // all or none
    // Where the half-plane's edge crosses the row.
    const double edge = (cx_ - row.dy_along / ux_) * per_sx_;
    if (ux_ > 0.0) return {first_where(row.from, row.to, edge, is_ahead), row.to};
    const auto behind = [&](std::int64_t a) { return !is_ahead(a); };
    return {row.from, first_where(row.from, row.to, edge, behind) - 1};
  }

  // Of `span`, a run of the row: where a test of d2 = dx^2 + dy^2 holds that holds nearer the
  // centre wherever it holds (d2 falls towards mid and rises from it). `half` is about the
  // run's half length (um).
  template <class Test>
  Run near(const DiscRow& row, const Run& span, double half, const Test& holds) const {
    const auto d2 = [&](std::int64_t a) {
      const double x = dx(a);
      return x * x + row.dy2;
    };
    const std::int64_t first =
        first_where(span.first, std::min(row.mid - 1, span.last), (cx_ - half) * per_sx_,
                    [&](std::int64_t a) { return holds(d2(a)); });
    const std::int64_t past =
        first_where(std::max(row.mid, span.first), span.last, (cx_ + half) * per_sx_,
                    [&](std::int64_t a) { return !holds(d2(a)); });
    return Run{first, past - 1} & span;
  }

 private:
  double dx(std::int64_t a) const { return static_cast<double>(a) * sx_ - cx_; }

  double cx_, sx_, per_sx_, ux_, uy_;
  std::int64_t from_, to_, mid_ = 0;
};

// The share of the A-scans in front of the sphere's centre, within reach, whose footprint
// disagrees with the sphere's: masked outside its disc or clear inside it (1 without any).
double footprint_mismatch(const Sphere& s, const Axis& axis, const MaskedRuns& masked, double sx,
                          double sy) {
  const double reach2 = s.reach * s.reach, r2 = s.r * s.r;
  const Disc disc(s, axis, sx);
  std::int64_t cells = 0, mismatches = 0;
  for (std::int64_t b = s.window.b_lo; b <= s.window.b_hi; ++b) {
    const double dy = static_cast<double>(b) * sy - s.cy;
    const double dy2 = dy * dy;
    if (dy2 > reach2) continue;
    // Every A-scan of the row is counted, but only the runs' ends are tested (a cell-by-cell count
    // would look at the chord and a cell beyond each end only: all those further away fail the
    // reach test by more than a cell's width); the chord only guesses where the ends lie.
    const double half_chord = std::sqrt(reach2 - dy2);
    const DiscRow row = disc.row(dy);
    const Run ahead = disc.ahead(row);
    if (ahead.size() == 0) continue;
    const Run in_reach =
        disc.near(row, ahead, half_chord, [&](double d2) { return !(d2 > reach2); });
    // d2 >= dy2: no A-scan of a row as far as r from the centre is inside.
    const Run inside = dy2 >= r2 ? Run{}
                                 : disc.near(row, in_reach, std::sqrt(r2 - dy2),
                                             [&](double d2) { return d2 < r2; });
    // The disc within reach's: its masked A-scans agree, the rest's disagree.
    const std::int64_t masked_in_reach = masked.count(b, in_reach);
    const std::int64_t masked_inside = masked.count(b, inside);
    cells += in_reach.size();
    mismatches += (masked_in_reach - masked_inside) + (inside.size() - masked_inside);
  }
  return cells > 0 ? static_cast<double>(mismatches) / static_cast<double>(cells) : 1.0;
}

// The depths of the sphere's centre its reflexes give: z = zc - sqrt(r^2 - d^2) (um of the
// medium) for those in front of the centre; their mean and variance (px), count >= 3.
struct CentreDepths {
  std::size_t count = 0;
  double mean = 0.0, variance = 0.0;
};

CentreDepths centre_depths(const std::vector<Reflex>& reflexes, const Sphere& s,
                           double um_per_px_medium) {
  double sum = 0.0, sum2 = 0.0;
  CentreDepths out;
  for (const Reflex& reflex : reflexes) {
    if (reflex.s < s.cs) break;
    const double ds = reflex.s - s.cs;
    const double d2 = ds * ds + reflex.dc * reflex.dc;
    if (d2 >= s.r * s.r) continue;
    const double zc = reflex.z + std::sqrt(s.r * s.r - d2) / um_per_px_medium;
    sum += zc;
    sum2 += zc * zc;
    ++out.count;
  }
  if (out.count < 3) return out;
  out.mean = sum / static_cast<double>(out.count);
  out.variance = std::max(0.0, sum2 / static_cast<double>(out.count) - out.mean * out.mean);
  return out;
}

struct Fit {
  double radius = 0.0, center_px = 0.0, cost = 1e300;
};

// The rounded end (a capsule's cap, the shape of every metal tool's end): a sphere of radius r
// whose rim is the footprint's extreme. In front of its centre every reflex lies on it. Tried for
// every r, the one whose reflexes agree best on the centre's depth zc and whose disc matches the
// footprint best wins (the smallest r of equal costs).
Fit fit_end(const End& end, const Axis& axis, const InstrumentFindings& f, double sx, double sy,
            double um_per_px_medium) {
  Fit best;
  const std::vector<Reflex> reflexes = reflexes_of(end, f, axis);
  if (reflexes.size() < 3) return best;  // no sphere sees three
  const std::vector<Sphere> spheres = spheres_of(end, axis, f, sx, sy);
  const MaskedRuns masked(f, covering(spheres));
  for (const Sphere& s : spheres) {
    // The footprint's share of the cost is a floor to it: a sphere that cannot beat the best
    // so far is not worth its reflexes' square roots.
    const double mismatch = footprint_mismatch(s, axis, masked, sx, sy);
    if (mismatch / kFootprintMismatch >= best.cost) continue;
    const CentreDepths depths = centre_depths(reflexes, s, um_per_px_medium);
    if (depths.count < 3) continue;
    const double cost = depths.variance / kDepthSpreadPx2 + mismatch / kFootprintMismatch;
    if (cost < best.cost) best = {s.r, depths.mean, cost};
  }
  return best;
}

// A flat (translucent) end, or too few reflexes for a sphere: the depth of the reflex nearest to
// the tip (a translucent tool's is the middle of its front and back surface).
double nearest_reflex_px(const End& end, const InstrumentFindings& f, const Axis& axis,
                         double tip_x, double tip_y) {
  double nearest = 1e300, depth_px = 0.0;
  for (const Place& c : end.cells) {
    if (f.mask[c.k] == ColumnKind::clear) continue;
    const double dx = axis.x(c) - tip_x;
    const double dy = axis.y(c) - tip_y;
    if (dx * dx + dy * dy < nearest) {
      nearest = dx * dx + dy * dy;
      depth_px = f.reflex_px[c.k];
    }
  }
  return depth_px;
}

InstrumentTip tip_of(const Footprint& fp, const InstrumentFindings& f,
                     const InstrumentConfig& config, const VolumeSampling& sampling) {
  const double sx = sampling.ascan_spacing_um, sy = sampling.bscan_spacing_um;
  const Axis axis = axis_of(fp.ascans, f, sx, sy);
  const End end = end_of(fp.ascans, f, axis, std::min(sx, sy));
  const double um_per_px_medium = sampling.axial_um_per_px / config.medium_group_index;
  const Fit fit = end.translucent ? Fit{} : fit_end(end, axis, f, sx, sy, um_per_px_medium);
  const bool fitted = fit.cost < 1e300;
  const double radius_um = fitted ? fit.radius : 0.0;
  const double tip_s = end.s_max + 0.5 * end.rim - radius_um;
  const double tip_x = axis.mx + tip_s * axis.ux - end.rim_across * axis.uy;
  const double tip_y = axis.my + tip_s * axis.uy + end.rim_across * axis.ux;
  InstrumentTip tip;
  tip.footprint_ascans = static_cast<std::uint32_t>(fp.ascans.size());
  tip.translucent = end.translucent;
  tip.ascan = tip_x / sx;
  tip.bscan = tip_y / sy;
  tip.depth_px = fitted ? fit.center_px : nearest_reflex_px(end, f, axis, tip_x, tip_y);
  tip.x_um = tip_x;
  tip.y_um = tip_y;
  tip.axis_x = axis.ux;
  tip.axis_y = axis.uy;
  tip.z_um = tip.depth_px * sampling.axial_um_per_px;
  return tip;
}

// A-scans classified as masked with at least kMinMaskedNeighbours of their 8 neighbours so too.
// Only the masked ones are looked at (most of a mask is clear).
void clean_mask(InstrumentFindings& f) {
  std::fill(f.mask.begin(), f.mask.end(), ColumnKind::clear);
  for (std::uint32_t b = 0; b < f.bscans; ++b) {
    const ColumnKind* row = &f.columns[f.index(b, 0)];
    for (std::size_t a = next_not_clear(row, 0, f.ascans); a < f.ascans;
         a = next_not_clear(row, a + 1, f.ascans)) {
      if (masked_neighbours(f, b, static_cast<std::int64_t>(a)) >=
          InstrumentFindings::kMinMaskedNeighbours) {
        f.mask[f.index(b, static_cast<std::uint32_t>(a))] = row[a];
      }
    }
  }
}

}  // namespace

void find_tips(InstrumentFindings& findings, const Surfaces& surfaces,
               const InstrumentConfig& config, const VolumeSampling& sampling) {
  clean_mask(findings);
  findings.tips.clear();
  findings.nearest = -1;
  findings.warning = false;
  std::vector<Footprint> found = footprints(findings, config.min_ascans);
  // The mask keeps the instruments' A-scans only (not a membrane's, a floater's, speckle's).
  std::fill(findings.mask.begin(), findings.mask.end(), ColumnKind::clear);
  for (const Footprint& fp : found) {
    for (const Place& p : fp.ascans) findings.mask[p.k] = findings.columns[p.k];
  }
  if (found.size() > InstrumentFindings::kMaxInstruments) {
    found.resize(InstrumentFindings::kMaxInstruments);
  }
  for (const Footprint& fp : found) {
    InstrumentTip tip = tip_of(fp, findings, config, sampling);
    const SurfaceAt at = surfaces_at(findings, surfaces, tip.bscan, tip.ascan, sampling);
    tip.source = at.source;
    tip.ilm_px = at.ilm;
    tip.rpe_px = at.rpe;
    if (at.source != DistanceSource::none) {
      tip.to_ilm_um = (at.ilm - tip.depth_px) * sampling.axial_um_per_px;
      tip.to_rpe_um = (at.rpe - tip.depth_px) * sampling.axial_um_per_px;
    }
    findings.tips.push_back(tip);
  }
  for (std::size_t i = 0; i < findings.tips.size(); ++i) {
    const InstrumentTip* best = findings.nearest_tip();
    const double to_rpe = findings.tips[i].to_rpe_um;
    if (best == nullptr ||
        (std::isfinite(to_rpe) && !(std::isfinite(best->to_rpe_um) && best->to_rpe_um <= to_rpe))) {
      findings.nearest = static_cast<std::int32_t>(i);
    }
  }
  const InstrumentTip* nearest = findings.nearest_tip();
  findings.warning = nearest != nullptr && std::isfinite(nearest->to_rpe_um) &&
                     nearest->to_rpe_um <= config.warn_rpe_um;
}

}  // namespace ioct::gpu::instruments
