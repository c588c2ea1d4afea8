#include "ioct/gpu/instruments/tip_finder.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <deque>
#include <limits>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

namespace ioct::gpu::instruments {
namespace {

using segmentation::Surfaces;
using segmentation::SurfaceState;

// The largest end radius tried (um): a 19 G shaft's.
constexpr double kMaxRadiusUm = 550.0;
// The end's fit tries radii and extremes this far apart (um), then this far about the best.
constexpr double kCoarseStepUm = 8.0;
constexpr double kFineStepUm = 2.0;
// The end's fit weighs the spread of its reflexes' centre depths (px^2) against the share of
// A-scans where its footprint disagrees with the sphere's: this much of each costs the same.
constexpr double kDepthSpreadPx2 = 4.0;
constexpr double kFootprintMismatch = 0.1;
// The end's axis and its middle across it are those of its last this many um: symmetric about
// the tool's axis (its rim's few A-scans are not), and short of a wider shaft that the border cuts.
constexpr double kAxisLengthUm = 600.0;
// A sphere seen by fewer reflexes is not tried: a few agree on any centre by chance.
constexpr std::size_t kMinEndReflexes = 6;
// Surfaces are taken this many A-scans away from the shadow mask at least.
constexpr std::int64_t kSurfaceMarginAscans = 2;
// On one side of the tip only, the surfaces' line is fitted to this many usable A-scans (or
// B-scans), within this many of the nearest.
constexpr double kSideSamples = 8.0;
constexpr std::int64_t kSideReach = 16;
// Under a tool the surfaces are a quadratic surface fitted to the usable A-scans within this
// distance of the tip (every second A-scan of each B-scan), when they surround it (some in each
// quadrant about it) and number at least kMinSurfaceFitSamples.
constexpr double kSurfaceFitRadiusUm = 300.0;
constexpr std::size_t kMinSurfaceFitSamples = 24;

// The first of kinds[from, n) that is not clear (n if none). Most of a mask is clear: 64, then
// eight A-scans are skipped at a time.
std::size_t next_not_clear(const ColumnKind* kinds, std::size_t from, std::size_t n) {
  static_assert(sizeof(ColumnKind) == 1 && static_cast<int>(ColumnKind::clear) == 0);
  if (from < n && kinds[from] != ColumnKind::clear) return from;  // inside a tool's footprint
  // Eight A-scans as one word, loaded straight into a register.
  const auto eight = [kinds](std::size_t at) {
    std::uint64_t word = 0;
    std::memcpy(&word, kinds + at, sizeof word);
    return word;
  };
  while (from + 64 <= n) {
    if ((eight(from) | eight(from + 8) | eight(from + 16) | eight(from + 24) | eight(from + 32) |
         eight(from + 40) | eight(from + 48) | eight(from + 56)) != 0) {
      break;
    }
    from += 64;
  }
  while (from + 8 <= n && eight(from) == 0) from += 8;
  while (from < n && kinds[from] == ColumnKind::clear) ++from;
  return from;
}

// An A-scan of the mask: its index, B-scan and A-scan (kept beside the index: recovering them
// from it takes a division, dearer than the rest of the work on an A-scan), and where it lies en
// face, um from the first voxel (worked out once, read by every pass over a footprint).
struct Place {
  std::uint32_t k = 0, b = 0, a = 0;
  double x = 0.0, y = 0.0;

  Place() = default;
  // A-scan a of B-scan b (index k), the A-scans sx and the B-scans sy um apart. A constructor, so
  // that emplace_back builds it in place (a copy of one built on the stack waits for its parts).
  Place(std::size_t index, std::uint32_t bscan, std::uint32_t ascan, double sx, double sy)
      : k(static_cast<std::uint32_t>(index)),
        b(bscan),
        a(ascan),
        x(static_cast<double>(ascan) * sx),
        y(static_cast<double>(bscan) * sy) {}
};

// A region of the mask: its A-scans in the order it grew in, and how many are fully shadowed.
struct Footprint {
  std::vector<Place> ascans;
  std::size_t metal = 0;
  std::size_t found = 0;  // the how-manieth kept region (they are found in the mask's order)
};

// Footprints kept from call to call (their A-scans' buffers with them): `used` of them hold this
// call's regions. A deque: a new one leaves those handed out where they are.
struct FootprintPool {
  std::deque<Footprint> all;
  std::size_t used = 0;

  Footprint& next() {
    if (used == all.size()) all.emplace_back();
    Footprint& fp = all[used];
    fp.ascans.clear();
    fp.metal = 0;
    fp.found = used++;
    return fp;
  }
  void drop_last() { --used; }
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

// The 8-connected region of the mask around `start`, grown depth first into `fp`; its A-scans are
// cleared in `open` (the masked A-scans in no region yet, as classified) as they are reached, and
// the fully shadowed ones counted. The stack holds (b, a) in one word: a store per neighbour
// instead of three.
void region_of(const InstrumentFindings& f, Place start, double sx, double sy, ColumnKind* open,
               std::vector<std::uint64_t>& stack, Footprint& fp) {
  const std::int64_t ascans = f.ascans;
  const auto packed = [](std::int64_t b, std::int64_t a) {
    return static_cast<std::uint64_t>(b) << 32 | static_cast<std::uint64_t>(a);
  };
  std::size_t metal = 0;
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
    fp.ascans.emplace_back(static_cast<std::size_t>(k), static_cast<std::uint32_t>(b),
                           static_cast<std::uint32_t>(a), sx, sy);
    // Its kind in the cleaned mask is its classification (open's is cleared by now).
    metal += f.columns[static_cast<std::size_t>(k)] == ColumnKind::shadow ? 1 : 0;
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
  fp.metal = metal;
}

// The instruments' footprints (regions of the cleaned mask in `open`, which they leave clear),
// largest first, into `tools`; into `loose` the regions only partly shadowed (each a membrane, a
// floater, or a paddle's part cut off from its tool: join_paddle_parts). Both point into `pool`.
void find_footprints(const InstrumentFindings& f, std::uint32_t min_ascans, double sx, double sy,
                     ColumnKind* open, std::vector<std::uint64_t>& stack, FootprintPool& pool,
                     std::vector<Footprint*>& tools, std::vector<const Footprint*>& loose) {
  pool.used = 0;
  tools.clear();
  loose.clear();
  for (std::uint32_t b = 0; b < f.bscans; ++b) {
    const ColumnKind* row = &open[f.index(b, 0)];
    for (std::size_t a = next_not_clear(row, 0, f.ascans); a < f.ascans;
         a = next_not_clear(row, a + 1, f.ascans)) {
      const auto start_a = static_cast<std::uint32_t>(a);
      Footprint& fp = pool.next();
      region_of(f, Place(f.index(b, start_a), b, start_a, sx, sy), sx, sy, open, stack, fp);
      // Every tool has metal (the scraper's paddle sits on a metal shaft): a footprint only
      // partly shadowed is a membrane or a floater lifted off the retina.
      if (fp.ascans.size() >= min_ascans && fp.metal >= min_ascans) {
        tools.push_back(&fp);
      } else if (fp.metal == 0) {
        loose.push_back(&fp);
      } else {
        pool.drop_last();
      }
    }
  }
  // Largest first, in the order found where as large (a stable sort's order; std::stable_sort
  // would allocate its buffer on every call).
  std::sort(tools.begin(), tools.end(), [](const Footprint* x, const Footprint* y) {
    return x->ascans.size() != y->ascans.size() ? x->ascans.size() > y->ascans.size()
                                                : x->found < y->found;
  });
}

// A surface (ILM or RPE, px) at fractional (bscan, ascan) from the nearest unshadowed, measured
// A-scans; `source` says whether the nearest A-scan itself was usable (measured) or the surfaces
// were interpolated from its neighbours (inferred).
struct SurfaceAt {
  double ilm = InstrumentTip::kNone;
  double rpe = InstrumentTip::kNone;
  DistanceSource source = DistanceSource::none;
};

// The ILM and RPE at (bscan, ascan) from z = c0 + c1 x + c2 y + c3 x^2 + c4 xy + c5 y^2 fitted by
// least squares to the `usable` A-scans within kSurfaceFitRadiusUm (x, y in units of that radius
// from the point, so the normal equations stay well scaled); nothing where they do not surround
// the point or are too few. A surface under a tool's shadow curves (the fovea's pit, the disc):
// a quadratic follows it where lines between the shadow's far sides cut the curve's chord (the
// appliance's forceps on the fovea's slope: the ILM 3.2 px too shallow by lines, 1.4 by this).
template <class Usable>
std::optional<SurfaceAt> fitted_surfaces_at(const InstrumentFindings& f, const Surfaces& s,
                                            double bscan, double ascan,
                                            const VolumeSampling& sampling, const Usable& usable) {
  const double radius = kSurfaceFitRadiusUm;
  const std::int64_t reach_a = static_cast<std::int64_t>(radius / sampling.ascan_spacing_um) + 1;
  const std::int64_t reach_b = static_cast<std::int64_t>(radius / sampling.bscan_spacing_um) + 1;
  const std::int64_t b_mid = std::lround(bscan), a_mid = std::lround(ascan);
  // [normal equations | ILM, RPE right-hand sides]
  double m[6][8] = {};
  std::size_t samples = 0;
  unsigned quadrants = 0;
  for (std::int64_t b = std::max<std::int64_t>(0, b_mid - reach_b);
       b <= std::min<std::int64_t>(f.bscans - 1, b_mid + reach_b); ++b) {
    const double y = (static_cast<double>(b) - bscan) * sampling.bscan_spacing_um / radius;
    for (std::int64_t a = std::max<std::int64_t>(0, a_mid - reach_a);
         a <= std::min<std::int64_t>(f.ascans - 1, a_mid + reach_a); a += 2) {
      const double x = (static_cast<double>(a) - ascan) * sampling.ascan_spacing_um / radius;
      if (x * x + y * y > 1.0 || !usable(b, a)) continue;
      const std::size_t k = f.index(static_cast<std::uint32_t>(b), static_cast<std::uint32_t>(a));
      const double t[6] = {1.0, x, y, x * x, x * y, y * y};
      for (int i = 0; i < 6; ++i) {
        for (int j = 0; j < 6; ++j) m[i][j] += t[i] * t[j];
        m[i][6] += t[i] * s.ilm[k];
        m[i][7] += t[i] * s.rpe[k];
      }
      quadrants |= 1u << ((x >= 0.0 ? 1 : 0) + (y >= 0.0 ? 2 : 0));
      ++samples;
    }
  }
  if (samples < kMinSurfaceFitSamples || quadrants != 15u) return std::nullopt;
  // Gauss-Jordan elimination with partial pivoting; a nearly singular system (the samples on a
  // line or two) gives nothing.
  for (int c = 0; c < 6; ++c) {
    int pivot = c;
    for (int r = c + 1; r < 6; ++r) {
      if (std::abs(m[r][c]) > std::abs(m[pivot][c])) pivot = r;
    }
    if (!(std::abs(m[pivot][c]) > 1e-9 * static_cast<double>(samples))) return std::nullopt;
    for (int j = 0; j < 8; ++j) std::swap(m[c][j], m[pivot][j]);
    for (int r = 0; r < 6; ++r) {
      if (r == c) continue;
      const double q = m[r][c] / m[c][c];
      for (int j = c; j < 8; ++j) m[r][j] -= q * m[c][j];
    }
  }
  // At the point itself x = y = 0: the constant term.
  return SurfaceAt{m[0][6] / m[0][0], m[0][7] / m[0][0], DistanceSource::inferred};
}

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
  if (const std::optional<SurfaceAt> fitted =
          fitted_surfaces_at(f, s, bscan, ascan, sampling, usable)) {
    return *fitted;
  }
  // Else (a tip near the volume's border, a shadow too wide for the fit's reach): along each axis
  // through the tip the nearest usable A-scan on either side, interpolated linearly where both
  // exist; each axis weighted by the inverse of its span in um.
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
      // One-sided: the retina slopes; a line through the side's nearest usable A-scans
      // (kSideSamples, within kSideReach of the first), evaluated at the tip.
      const std::int64_t i = has_lo ? lo : hi;
      const std::int64_t step = has_lo ? -1 : 1;
      double count = 0.0, t_sum = 0.0, tt_sum = 0.0, side_ilm = 0.0, side_rpe = 0.0;
      double t_ilm = 0.0, t_rpe = 0.0;
      for (std::int64_t j = i;
           j >= 0 && j < n && count < kSideSamples && std::abs(j - i) <= kSideReach; j += step) {
        if (!ok(j)) continue;
        const double t = static_cast<double>(j) - at;
        const std::size_t k = index_of(j);
        count += 1.0;
        t_sum += t;
        tt_sum += t * t;
        side_ilm += s.ilm[k];
        side_rpe += s.rpe[k];
        t_ilm += t * s.ilm[k];
        t_rpe += t * s.rpe[k];
      }
      const double spread = tt_sum - t_sum * t_sum / count;
      if (count >= 3.0 && spread > 0.0) {
        // The lines' values at t = 0.
        const double ilm_slope = (t_ilm - t_sum * side_ilm / count) / spread;
        const double rpe_slope = (t_rpe - t_sum * side_rpe / count) / spread;
        ilm = (side_ilm - ilm_slope * t_sum) / count;
        rpe = (side_rpe - rpe_slope * t_sum) / count;
      } else {
        ilm = s.ilm[index_of(i)];
        rpe = s.rpe[index_of(i)];
      }
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
  double x(const Place& p) const { return p.x; }
  double y(const Place& p) const { return p.y; }
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
  double mx = 0.0, my = 0.0;  // in registers, not in the axis
  for (const Place& c : cells) {
    mx += axis.x(c);
    my += axis.y(c);
  }
  const double n = static_cast<double>(cells.size());
  axis.mx = mx / n;
  axis.my = my / n;
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

// Each cell's place along the axis (um), into `along`.
void places_along(const std::vector<Place>& cells, const Axis& axis, std::vector<double>& along) {
  const Axis a = axis;  // a local copy: the stores below cannot change it, it stays in registers
  along.resize(cells.size());
  double* out = along.data();
  for (std::size_t i = 0; i < cells.size(); ++i) out[i] = a.along(cells[i]);
}

// The largest of `values` (-1e300 for none). Four running maxima: one would wait on its own last
// result at every value.
double largest(const std::vector<double>& values) {
  double m0 = -1e300, m1 = -1e300, m2 = -1e300, m3 = -1e300;
  const double* v = values.data();
  const std::size_t n = values.size();
  std::size_t i = 0;
  for (; i + 4 <= n; i += 4) {
    m0 = std::max(m0, v[i]);
    m1 = std::max(m1, v[i + 1]);
    m2 = std::max(m2, v[i + 2]);
    m3 = std::max(m3, v[i + 3]);
  }
  for (; i < n; ++i) m0 = std::max(m0, v[i]);
  return std::max(std::max(m0, m1), std::max(m2, m3));
}

// The footprint's end: its A-scans within twice the largest radius of its extreme along the axis
// (all the fit looks at); rim, one lateral sample; the tool's axis across the footprint's axis
// (the mean offset of the end's last kAxisLengthUm).
struct End {
  std::vector<Place> cells;
  std::vector<double> along;  // each cell's place along the axis (um)
  double s_max = -1e300, rim = 0.0, mid_across = 0.0;
  bool translucent = false;
  std::vector<double> all_along;  // the footprint's every A-scan's (kept for the next call)
};

void end_of(const std::vector<Place>& cells, const InstrumentFindings& f, const Axis& axis,
            double rim, End& end) {
  end.rim = rim;
  std::vector<double>& along = end.all_along;
  places_along(cells, axis, along);
  const double s_max = largest(along);
  end.s_max = s_max;
  // Counted, then copied into place (sized once: no push_back per A-scan).
  const double from = s_max - 2.0 * kMaxRadiusUm;
  const std::size_t n = cells.size();
  const double* const s = along.data();
  std::size_t kept = 0;
  for (std::size_t i = 0; i < n; ++i) kept += s[i] >= from ? 1 : 0;
  end.cells.resize(kept);
  end.along.resize(kept);
  Place* const end_cells = end.cells.data();
  double* const end_along = end.along.data();
  const Place* const cell = cells.data();
  for (std::size_t i = 0, j = 0; i < n; ++i) {
    if (s[i] < from) continue;
    end_cells[j] = cell[i];
    end_along[j] = s[i];
    ++j;
  }
  std::size_t mid_count = 0, partial = 0, shadow = 0;
  double mid_across = 0.0;
  const std::size_t end_n = end.cells.size();
  const Place* const end_cell = end.cells.data();
  const double* const end_s = end.along.data();
  for (std::size_t i = 0; i < end_n; ++i) {
    if (end_s[i] >= s_max - kAxisLengthUm) {
      mid_across += axis.across(end_cell[i]);
      ++mid_count;
    }
    if (end_s[i] >= s_max - 2.0 * rim) {
      (f.mask[end_cell[i].k] == ColumnKind::partial ? partial : shadow) += 1;
    }
  }
  end.mid_across = mid_across / static_cast<double>(mid_count);
  end.translucent = partial > shadow;
  if (!end.translucent) {
    // A metal end's rim is its metal's extreme: a partly shadowed A-scan ahead of it is the
    // retina beside the tip classified on its own (its "reflex" the retina's surface), not the
    // tool, and would put the rim, and with it the sphere's centre, a sample or more too far.
    double metal_max = -1e300;
    for (std::size_t i = 0; i < end_n; ++i) {
      if (f.mask[end_cell[i].k] == ColumnKind::shadow) metal_max = std::max(metal_max, end_s[i]);
    }
    if (metal_max > -1e300) end.s_max = metal_max;
  }
}

// A shadowed A-scan of the end: along and across (from the rim) the axis in um, its reflex in px.
struct Reflex {
  double s, dc, z;
};

// Nearest the extreme first: a sphere sees only those in front of its centre, a prefix of this
// list that grows with its radius.
void reflexes_of(const End& end, const InstrumentFindings& f, const Axis& axis,
                 std::vector<Reflex>& reflexes) {
  reflexes.clear();
  for (std::size_t i = 0; i < end.cells.size(); ++i) {
    const Place& c = end.cells[i];
    if (f.mask[c.k] == ColumnKind::shadow) {
      reflexes.push_back({end.along[i], axis.across(c) - end.mid_across, f.reflex_px[c.k]});
    }
  }
  std::sort(reflexes.begin(), reflexes.end(),
            [](const Reflex& x, const Reflex& y) { return x.s > y.s; });
}

// How steeply the tool rises towards its shaft, behind a point of its axis: the tangent of its
// pitch (um of the medium's depth per um en face) from the ridge of its reflexes (the shallowest
// per bin of one lateral sample along the axis: the top line of a cylinder, whatever its radius),
// the median of the ridge's slopes over kRiseBaseUm behind that point (robust to a wider shaft's
// end and the cap in the window). Per bin boundary (bins from the end's first reflex up to the
// extreme, `rim` wide); 0 (a level tool) with fewer than kMinRiseSlopes slopes or a ridge that
// rises towards the tip.
constexpr double kRiseBaseUm = 100.0;
constexpr std::size_t kMinRiseSlopes = 5;

struct Rise {
  double first = 0.0, bin = 1.0;
  std::vector<double> behind;              // [bin]: the tangent behind the bin's start
  std::vector<double> top, sorted_slopes;  // rise_of's own (kept for the next call)
  double at(double s) const {
    if (behind.empty() || s <= first) return 0.0;
    const auto i = static_cast<std::size_t>((s - first) / bin);
    return behind[std::min(i, behind.size() - 1)];
  }
};

void rise_of(const std::vector<Reflex>& reflexes, const End& end, double um_per_px_medium,
             Rise& rise) {
  rise.first = end.s_max - 2.0 * kMaxRadiusUm;
  rise.bin = end.rim;
  const auto bins = static_cast<std::size_t>(std::ceil((end.s_max - rise.first) / end.rim)) + 1;
  std::vector<double>& top = rise.top;
  top.assign(bins, std::numeric_limits<double>::infinity());
  for (const Reflex& r : reflexes) {
    if (r.s < rise.first) continue;
    const auto i = std::min(bins - 1, static_cast<std::size_t>((r.s - rise.first) / end.rim));
    top[i] = std::min(top[i], r.z);
  }
  const std::size_t apart =
      std::max<std::size_t>(1, static_cast<std::size_t>(kRiseBaseUm / end.rim));
  const double per_base = um_per_px_medium / (static_cast<double>(apart) * end.rim);
  rise.behind.assign(bins, 0.0);
  // The slopes so far, kept sorted: each bin's median is a look-up.
  std::vector<double>& sorted = rise.sorted_slopes;
  sorted.clear();
  for (std::size_t i = apart; i < bins; ++i) {
    // Pairs ending before bin i.
    const std::size_t j = i - 1;
    if (j >= apart && std::isfinite(top[j]) && std::isfinite(top[j - apart])) {
      const double slope = (top[j] - top[j - apart]) * per_base;
      sorted.insert(std::upper_bound(sorted.begin(), sorted.end(), slope), slope);
    }
    if (sorted.size() < kMinRiseSlopes) continue;
    rise.behind[i] = std::max(0.0, sorted[sorted.size() / 2]);
  }
}

// Mask rows [b_lo, b_hi], A-scans [a_lo, a_hi] of each.
struct Window {
  std::int64_t b_lo = 0, b_hi = -1, a_lo = 0, a_hi = -1;
  bool empty() const { return b_lo > b_hi || a_lo > a_hi; }
};

// A candidate end: a sphere of radius r whose rim is (about) the footprint's extreme, its centre cs
// along the axis and (cx, cy) en face (um). Its footprint is compared out to reach, a sample
// further, over the A-scans of `window`.
struct Sphere {
  double r = 0.0, cs = 0.0, cx = 0.0, cy = 0.0, reach = 0.0;
  Window window;
};

// The candidate ends: radii [r_lo, r_hi] by r_step, and the extreme e in [e_lo, e_hi) by e_step
// beyond the footprint's last A-scan along the axis (the true extreme lies before the next sample
// along it: up to a B-scan's spacing where the axis runs across B-scans).
struct SphereGrid {
  double r_lo, r_hi, r_step, e_lo, e_hi, e_step;
};

void spheres_of(const End& end, const Axis& axis, const InstrumentFindings& f, double sx, double sy,
                const SphereGrid& grid, std::vector<Sphere>& spheres) {
  spheres.clear();
  for (double r = grid.r_lo; r <= grid.r_hi; r += grid.r_step) {
    for (double e = grid.e_lo; e < grid.e_hi; e += grid.e_step) {
      Sphere s;
      s.r = r;
      s.cs = end.s_max + e - r;
      s.reach = r + end.rim;
      s.cx = axis.mx + s.cs * axis.ux - end.mid_across * axis.uy;
      s.cy = axis.my + s.cs * axis.uy + end.mid_across * axis.ux;
      // Wide enough: the tests decide (the casts round towards 0, hence a sample more each side).
      s.window.a_lo =
          std::max<std::int64_t>(0, static_cast<std::int64_t>((s.cx - s.reach) / sx) - 1);
      s.window.a_hi = std::min<std::int64_t>(f.ascans - 1,
                                             static_cast<std::int64_t>((s.cx + s.reach) / sx) + 1);
      s.window.b_lo =
          std::max<std::int64_t>(0, static_cast<std::int64_t>((s.cy - s.reach) / sy) - 1);
      s.window.b_hi = std::min<std::int64_t>(f.bscans - 1,
                                             static_cast<std::int64_t>((s.cy + s.reach) / sy) + 1);
      spheres.push_back(s);
    }
  }
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
  // Over `window` of f's mask (the counts' buffer kept for the next window).
  void reset(const InstrumentFindings& f, const Window& window) {
    window_ = window;
    stride_ = window.a_hi - window.a_lo + 2;
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
  std::int64_t stride_ = 0;
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

// At least as many A-scans as footprint_mismatch counts within reach ahead of the sphere's
// centre, without its tests at every run's ends: per row within reach, the integers of the real
// interval where the reach about the centre (the row's chord is no longer), the half-plane ahead
// and the window meet, widened by far more than the tests' rounding (a millionth of the um
// involved).
double cells_in_reach_at_most(const Sphere& s, const Axis& axis, double sx, double sy) {
  const double reach2 = s.reach * s.reach;
  const double slack = 1e-6 * (1.0 + std::abs(s.cx) + s.reach);  // um
  const double window_lo = static_cast<double>(s.window.a_lo) * sx - slack;
  const double window_hi = static_cast<double>(s.window.a_hi) * sx + slack;
  // A half-plane edge nearly along the row bounds nothing worth its rounding.
  const bool edge_bounds = std::abs(axis.ux) >= 1e-3;
  const double along_per_ux = edge_bounds ? axis.uy / axis.ux : 0.0;
  const double per_sx = 1.0 / sx;
  double total = 0.0;
  for (std::int64_t b = s.window.b_lo; b <= s.window.b_hi; ++b) {
    const double dy = static_cast<double>(b) * sy - s.cy;
    const double dy2 = dy * dy;
    if (dy2 > reach2) continue;
    // The chord's half is at most the reach: its square root would cost more than it saves.
    double lo = std::max(window_lo, s.cx - s.reach - slack);
    double hi = std::min(window_hi, s.cx + s.reach + slack);
    if (edge_bounds) {
      const double edge = s.cx - dy * along_per_ux;
      if (axis.ux > 0.0) {
        lo = std::max(lo, edge - slack);
      } else {
        hi = std::min(hi, edge + slack);
      }
    }
    // The integers of [lo, hi] / sx: at most (hi - lo) / sx + 1.
    total += std::max(0.0, (hi - lo) * per_sx + 1.0);
  }
  return total * (1.0 + 1e-9) + 1e-6;  // and the rounding of 1 / sx and of the sum
}

// The share of the A-scans in front of the sphere's centre, within reach, whose footprint
// disagrees with the sphere's: masked outside its disc or clear inside it (1 without any).
// Where that share cannot make the cost `give_up` or less (share / kFootprintMismatch >=
// give_up), the rows are left as soon as that is sure, and a part of the share is returned: the
// mismatches found by then over at least as many A-scans as there are (cells_in_reach_at_most),
// as sure to lose, since the share is larger.
double footprint_mismatch(const Sphere& s, const Axis& axis, const MaskedRuns& masked, double sx,
                          double sy, double give_up) {
  const double reach2 = s.reach * s.reach, r2 = s.r * s.r;
  const Disc disc(s, axis, sx);
  // A share is at most 1: above 1 / kFootprintMismatch no sphere is given up.
  const double cells_at_most =
      give_up <= 1.0 / kFootprintMismatch ? cells_in_reach_at_most(s, axis, sx, sy) : 0.0;
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
    const std::int64_t row_mismatches =
        (masked_in_reach - masked_inside) + (inside.size() - masked_inside);
    cells += in_reach.size();
    mismatches += row_mismatches;
    if (row_mismatches > 0 && cells_at_most > 0.0) {
      const double share_at_least = static_cast<double>(mismatches) / cells_at_most;
      if (share_at_least / kFootprintMismatch >= give_up) return share_at_least;
    }
  }
  return cells > 0 ? static_cast<double>(mismatches) / static_cast<double>(cells) : 1.0;
}

// The depths of the sphere's centre its reflexes give: z = zc - (the capsule's top above its axis
// there, um of the medium) for those in front of the centre; their mean and (unbiased) variance
// (px), count >= kMinEndReflexes.
struct CentreDepths {
  std::size_t count = 0;
  double mean = 0.0, variance = 0.0;
};

// The tool's pitch p as the end's fit uses it.
struct Pitch {
  double tan = 0.0, sin = 0.0, per_cos = 1.0;
  explicit Pitch(double tan_p)
      : tan(tan_p),
        sin(tan_p / std::sqrt(1.0 + tan_p * tan_p)),
        per_cos(std::sqrt(1.0 + tan_p * tan_p)) {}
};

CentreDepths centre_depths(const std::vector<Reflex>& reflexes, const Sphere& s, const Pitch& pitch,
                           double um_per_px_medium) {
  double sum = 0.0, sum2 = 0.0;
  CentreDepths out;
  for (const Reflex& reflex : reflexes) {
    if (reflex.s < s.cs) break;
    const double f = reflex.s - s.cs;
    const double rr = s.r * s.r - reflex.dc * reflex.dc;
    if (f * f >= rr) continue;
    // The capsule's top above its axis at (f ahead, dc across): with R^2 = r^2 - dc^2 the cap's
    // sqrt(R^2 - f^2) where f > R sin p, else the cylinder rising behind it, R / cos p - f tan p
    // (a pitched tool's cylinder hides the front of its cap from the beam).
    const double rc = std::sqrt(rr);
    const double above =
        f > rc * pitch.sin ? std::sqrt(rr - f * f) : rc * pitch.per_cos - f * pitch.tan;
    const double zc = reflex.z + above / um_per_px_medium;
    sum += zc;
    sum2 += zc * zc;
    ++out.count;
  }
  if (out.count < kMinEndReflexes) return out;
  const auto n = static_cast<double>(out.count);
  out.mean = sum / n;
  out.variance = std::max(0.0, sum2 / n - out.mean * out.mean) * n / (n - 1.0);
  return out;
}

// The end's sphere: its radius (um), its centre's depth (px) and place along the axis (um).
struct Fit {
  double radius = 0.0, center_px = 0.0, cost = 1e300, cs = 0.0;
};

// What the end's fit works in, kept from call to call.
struct FitBuffers {
  End end;
  std::vector<Reflex> reflexes;
  Rise rise;
  std::vector<Sphere> spheres;
  MaskedRuns masked;
};

// The rounded end (a capsule's cap, the shape of every metal tool's end): a sphere of radius r
// whose rim is the footprint's extreme (up to a sample beyond its last A-scan). In front of its
// centre every reflex lies on the capsule's top (centre_depths). Tried for every r and extreme
// (coarse, then fine), the one whose reflexes agree best on the centre's depth zc and whose disc
// matches the footprint best wins (the smallest r of equal costs).
Fit fit_end(const End& end, const Axis& axis, const InstrumentFindings& f, double sx, double sy,
            double um_per_px_medium, FitBuffers& buffers) {
  Fit best;
  std::vector<Reflex>& reflexes = buffers.reflexes;
  reflexes_of(end, f, axis, reflexes);
  if (reflexes.size() < kMinEndReflexes) return best;  // no sphere sees enough
  Rise& rise = buffers.rise;
  rise_of(reflexes, end, um_per_px_medium, rise);
  const auto search = [&](const SphereGrid& grid) {
    std::vector<Sphere>& spheres = buffers.spheres;
    spheres_of(end, axis, f, sx, sy, grid, spheres);
    MaskedRuns& masked = buffers.masked;
    masked.reset(f, covering(spheres));
    for (const Sphere& s : spheres) {
      // The footprint's share of the cost is a floor to it: a sphere that cannot beat the best
      // so far is not worth its reflexes' square roots.
      const double mismatch = footprint_mismatch(s, axis, masked, sx, sy, best.cost);
      if (mismatch / kFootprintMismatch >= best.cost) continue;
      const CentreDepths depths =
          centre_depths(reflexes, s, Pitch(rise.at(s.cs)), um_per_px_medium);
      if (depths.count < kMinEndReflexes) continue;
      const double cost = depths.variance / kDepthSpreadPx2 + mismatch / kFootprintMismatch;
      if (cost < best.cost) best = {s.r, depths.mean, cost, s.cs};
    }
  };
  // Coarse, then fine about the best (the cost varies smoothly with both).
  const double beyond = std::max(std::abs(axis.ux) * sx, std::abs(axis.uy) * sy);
  search({2.0 * end.rim, kMaxRadiusUm, kCoarseStepUm, 0.0, beyond, kCoarseStepUm});
  if (best.cost >= 1e300) return best;
  const double e = best.cs + best.radius - end.s_max;
  search({std::max(2.0 * end.rim, best.radius - kCoarseStepUm),
          std::min(kMaxRadiusUm, best.radius + kCoarseStepUm), kFineStepUm,
          std::max(0.0, e - kCoarseStepUm), std::min(beyond, e + kCoarseStepUm), kFineStepUm});
  return best;
}

// Too few reflexes for a sphere: the depth of the reflex nearest to the tip.
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

// Where an end's tip is (um en face, depth px).
struct EndTip {
  double x = 0.0, y = 0.0, depth_px = 0.0;
  bool translucent = false;
};

// A rounded metal end (tip_finder.hpp, 3.), or a translucent end at its rim at the depth of the
// tool's middle there.
EndTip tip_of_end(const std::vector<Place>& cells, const InstrumentFindings& f, const Axis& axis,
                  double sx, double sy, double um_per_px_medium, FitBuffers& buffers) {
  End& end = buffers.end;
  end_of(cells, f, axis, std::min(sx, sy), end);
  const Fit fit =
      end.translucent ? Fit{} : fit_end(end, axis, f, sx, sy, um_per_px_medium, buffers);
  const bool fitted = fit.cost < 1e300;
  const double tip_s = fitted ? fit.cs : end.s_max + 0.5 * end.rim;
  EndTip tip;
  tip.translucent = end.translucent;
  tip.x = axis.mx + tip_s * axis.ux - end.mid_across * axis.uy;
  tip.y = axis.my + tip_s * axis.uy + end.mid_across * axis.ux;
  tip.depth_px = fitted ? fit.center_px : nearest_reflex_px(end, f, axis, tip.x, tip.y);
  return tip;
}

// The footprint's A-scans within kProngLengthUm of its extreme, split into 8-connected parts: an
// open forceps' two jaws, apart there, each a prong of its own (a closed tool has one). Parts of
// fewer than kMinProngAscans A-scans, or ending further than half kProngLengthUm behind the
// extreme, are not prongs.
constexpr double kProngLengthUm = 300.0;
constexpr std::size_t kMinProngAscans = 12;

// An end's prongs (their A-scans' buffers kept from call to call: `count` of them are this
// call's), and what prongs_of works in.
struct Prongs {
  std::vector<std::vector<Place>> all;
  std::size_t count = 0;
  std::vector<std::size_t> near, index_of, stack;
  std::vector<std::uint8_t> grid;

  const std::vector<Place>& operator[](std::size_t i) const { return all[i]; }
};

// Of `cells`, whose places along the axis are `along` and extreme s_max (worked out by the caller:
// an end has them already).
void prongs_of(const std::vector<Place>& cells, const std::vector<double>& along, double s_max,
               Prongs& prongs) {
  prongs.count = 0;
  std::vector<std::size_t>& near = prongs.near;
  near.clear();
  std::uint32_t b_lo = ~0u, b_hi = 0, a_lo = ~0u, a_hi = 0;
  for (std::size_t i = 0; i < cells.size(); ++i) {
    if (along[i] < s_max - kProngLengthUm) continue;
    near.push_back(i);
    b_lo = std::min(b_lo, cells[i].b);
    b_hi = std::max(b_hi, cells[i].b);
    a_lo = std::min(a_lo, cells[i].a);
    a_hi = std::max(a_hi, cells[i].a);
  }
  if (near.empty()) return;
  // Labels over the parts' bounding box: 0 none, 1 unvisited, 2 visited.
  const std::size_t width = a_hi - a_lo + 1, height = b_hi - b_lo + 1;
  std::vector<std::uint8_t>& grid = prongs.grid;
  grid.assign(width * height, 0);
  std::vector<std::size_t>& index_of = prongs.index_of;
  index_of.resize(width * height);
  for (const std::size_t i : near) {
    const std::size_t g = (cells[i].b - b_lo) * width + (cells[i].a - a_lo);
    grid[g] = 1;
    index_of[g] = i;
  }
  std::vector<std::size_t>& stack = prongs.stack;
  for (const std::size_t seed : near) {
    const std::size_t g0 = (cells[seed].b - b_lo) * width + (cells[seed].a - a_lo);
    if (grid[g0] != 1) continue;
    if (prongs.count == prongs.all.size()) prongs.all.emplace_back();
    std::vector<Place>& prong = prongs.all[prongs.count];
    prong.clear();
    double prong_max = -1e300;
    grid[g0] = 2;
    stack.assign(1, g0);
    while (!stack.empty()) {
      const std::size_t g = stack.back();
      stack.pop_back();
      prong.push_back(cells[index_of[g]]);
      prong_max = std::max(prong_max, along[index_of[g]]);
      const auto gb = static_cast<std::int64_t>(g / width),
                 ga = static_cast<std::int64_t>(g % width);
      for (const auto& [db, da] : kNeighbours) {
        const std::int64_t nb = gb + db, na = ga + da;
        if (nb < 0 || na < 0 || nb >= static_cast<std::int64_t>(height) ||
            na >= static_cast<std::int64_t>(width)) {
          continue;
        }
        const auto n = static_cast<std::size_t>(nb) * width + static_cast<std::size_t>(na);
        if (grid[n] == 1) {
          grid[n] = 2;
          stack.push_back(n);
        }
      }
    }
    if (prong.size() >= kMinProngAscans && prong_max >= s_max - 0.5 * kProngLengthUm) {
      ++prongs.count;
    }
  }
}

// Classified as partly shadowed by the column code (not grown onto the paddle: extend_paddle).
bool classified_partial(const InstrumentFindings& f, const Place& c) {
  return f.mask[c.k] == ColumnKind::partial && f.front_px[c.k] > 0.0f;
}

// Half the paddle's height in an A-scan (px, from its front surface to its middle): the median
// over its classified A-scans; 0 without any. `half_heights`: a buffer for them.
double median_half_height(const std::vector<Place>& cells, const InstrumentFindings& f,
                          std::vector<double>& half_heights) {
  half_heights.clear();
  for (const Place& c : cells) {
    if (classified_partial(f, c)) half_heights.push_back(f.reflex_px[c.k] - f.front_px[c.k]);
  }
  if (half_heights.empty()) return 0.0;
  std::nth_element(half_heights.begin(), half_heights.begin() + half_heights.size() / 2,
                   half_heights.end());
  return half_heights[half_heights.size() / 2];
}

// A plane z = z0 + g . (x - x0, y - y0) (px; x, y um) through reflexes, by least squares.
struct Plane {
  double x0 = 0.0, y0 = 0.0, z0 = 0.0, gx = 0.0, gy = 0.0;
  bool valid = false;  // three reflexes or more, not all on one line
  double at(double x, double y) const { return z0 + gx * (x - x0) + gy * (y - y0); }
};

// The plane through the reflexes of the `cells` that `take` accepts, in `axis`'s frame.
template <class Take>
Plane reflex_plane(const std::vector<Place>& cells, const InstrumentFindings& f, const Axis& axis,
                   Take&& take) {
  Plane plane;
  // The sums in locals (registers), not in the plane (memory): each add waits on the last.
  double n = 0.0, x0 = 0.0, y0 = 0.0, z0 = 0.0;
  for (const Place& c : cells) {
    if (!take(c)) continue;
    n += 1.0;
    x0 += axis.x(c);
    y0 += axis.y(c);
    z0 += f.reflex_px[c.k];
  }
  plane.x0 = x0;
  plane.y0 = y0;
  plane.z0 = z0;
  if (n < 3.0) return plane;
  plane.x0 /= n;
  plane.y0 /= n;
  plane.z0 /= n;
  double xx = 0.0, xy = 0.0, yy = 0.0, xz = 0.0, yz = 0.0;
  for (const Place& c : cells) {
    if (!take(c)) continue;
    const double dx = axis.x(c) - plane.x0, dy = axis.y(c) - plane.y0;
    const double dz = f.reflex_px[c.k] - plane.z0;
    xx += dx * dx;
    xy += dx * dy;
    yy += dy * dy;
    xz += dx * dz;
    yz += dy * dz;
  }
  const double det = xx * yy - xy * xy;
  if (!(det > 0.0)) return plane;
  plane.gx = (yy * xz - xy * yz) / det;
  plane.gy = (xx * yz - xy * xz) / det;
  plane.valid = true;
  return plane;
}

// A translucent tool's paddle: a tilted plate, whose middle is the plane through its A-scans'
// reflexes.
Plane paddle_plane(const std::vector<Place>& cells, const InstrumentFindings& f, const Axis& axis) {
  return reflex_plane(cells, f, axis, [&](const Place& c) { return classified_partial(f, c); });
}

// The paddle deepens towards its leading edge: its axis is the plane's gradient where it is
// pitched by more than kMinPaddleRise (else the footprint's). The tip is the middle of the leading
// edge (instrument_truth.hpp): the footprint's A-scans within two samples along the axis of its
// extreme give the edge's ends across it, and the plane its depth.
constexpr double kMinPaddleRise = 0.1;

EndTip tip_of_paddle(const std::vector<Place>& cells, const InstrumentFindings& f,
                     const Axis& principal, double sx, double sy, double um_per_px_medium,
                     Axis& axis, std::vector<double>& scratch) {
  axis = principal;
  const Plane plane = paddle_plane(cells, f, principal);
  const double g = std::hypot(plane.gx, plane.gy);
  const bool pitched = plane.valid && g * um_per_px_medium >= kMinPaddleRise;
  if (pitched) {
    axis.ux = plane.gx / g;
    axis.uy = plane.gy / g;
  }
  double s_max = -1e300;
  for (const Place& c : cells) s_max = std::max(s_max, axis.along(c));
  const double step = std::max(std::abs(axis.ux) * sx, std::abs(axis.uy) * sy);
  double lo = 1e300, hi = -1e300;
  for (const Place& c : cells) {
    if (!classified_partial(f, c) && axis.along(c) < s_max - 2.0 * step) continue;
    lo = std::min(lo, axis.across(c));
    hi = std::max(hi, axis.across(c));
  }
  // The footprint ends at the leading face's top edge, which lies h sin p ahead of the face's
  // middle (h: half the paddle's thickness, its half height in an A-scan times cos p).
  const double half_height = median_half_height(cells, f, scratch);
  double ahead = 0.0;
  if (pitched && half_height > 0.0) {
    const double tan_p = g * um_per_px_medium;
    const double half_height_um = half_height * um_per_px_medium;
    ahead = half_height_um * tan_p / (1.0 + tan_p * tan_p);  // h_v cos p sin p
  }
  const double tip_s = s_max + 0.5 * std::min(sx, sy) - ahead, tip_c = 0.5 * (lo + hi);
  EndTip tip;
  tip.translucent = true;
  tip.x = axis.mx + tip_s * axis.ux - tip_c * axis.uy;
  tip.y = axis.my + tip_s * axis.uy + tip_c * axis.ux;
  tip.depth_px = plane.valid ? plane.at(tip.x, tip.y) : 0.0;
  return tip;
}

// A paddle on or just above the retina has no long dark gap beneath it: its A-scans there are not
// classified (column_classification.hpp), and the footprint stops short of the leading edge. The
// segmentation's ILM there is the paddle's front surface: half the paddle's height above its
// middle plane. The footprint grows into the clear A-scans around it whose ILM lies on that front
// (within kPaddleOnIlmPx); they join the mask as partly shadowed, their reflex on the plane. Ahead
// of the paddle the retina lies below its front, and meets the front's plane only further on.
constexpr double kPaddleOnIlmPx = 3.0;
// How far ahead of a paddle's classified part it is looked for (um along its axis).
constexpr double kPaddleReachUm = 300.0;

void extend_paddle(Footprint& fp, InstrumentFindings& f, const Surfaces& s, const Axis& principal,
                   std::vector<Place>& pending, std::vector<double>& scratch) {
  if (s.bscans != f.bscans || s.ascans != f.ascans) return;
  const Plane plane = paddle_plane(fp.ascans, f, principal);
  const double g = std::hypot(plane.gx, plane.gy);
  if (!plane.valid || g == 0.0) return;
  Axis axis = principal;
  axis.ux = plane.gx / g;
  axis.uy = plane.gy / g;
  const auto ilm_at = [&](std::size_t k) {
    return s.state[k] == SurfaceState::measured && std::isfinite(s.ilm[k]) ? double{s.ilm[k]}
                                                                           : std::nan("");
  };
  const double height = median_half_height(fp.ascans, f, scratch);
  if (!(height > 0.0)) return;
  // Within the paddle's width and kPaddleReachUm ahead of its classified part: further on, the
  // front's plane meets the retina ahead of the paddle.
  double s_max = -1e300, lo = 1e300, hi = -1e300;
  for (const Place& c : fp.ascans) {
    if (!classified_partial(f, c)) continue;
    s_max = std::max(s_max, axis.along(c));
    lo = std::min(lo, axis.across(c));
    hi = std::max(hi, axis.across(c));
  }
  const auto on_paddle = [&](std::int64_t b, std::int64_t a) {
    const std::size_t k = f.index(static_cast<std::uint32_t>(b), static_cast<std::uint32_t>(a));
    if (f.mask[k] != ColumnKind::clear) return false;
    const double ilm = ilm_at(k);
    const Place p =
        Place(k, static_cast<std::uint32_t>(b), static_cast<std::uint32_t>(a), axis.sx, axis.sy);
    const double across = axis.across(p);
    return std::isfinite(ilm) && axis.along(p) <= s_max + kPaddleReachUm && across >= lo &&
           across <= hi &&
           std::abs(plane.at(axis.x(p), axis.y(p)) - ilm - height) <= kPaddleOnIlmPx;
  };
  pending = fp.ascans;
  while (!pending.empty()) {
    const Place c = pending.back();
    pending.pop_back();
    for (const auto& [db, da] : kNeighbours) {
      const std::int64_t b = std::int64_t{c.b} + db, a = std::int64_t{c.a} + da;
      if (!inside_mask(f, b, a) || !on_paddle(b, a)) continue;
      const auto pb = static_cast<std::uint32_t>(b), pa = static_cast<std::uint32_t>(a);
      const Place p = Place(f.index(pb, pa), pb, pa, axis.sx, axis.sy);
      f.mask[p.k] = ColumnKind::partial;
      f.reflex_px[p.k] = static_cast<float>(plane.at(axis.x(p), axis.y(p)));
      fp.ascans.push_back(p);
      pending.push_back(p);
    }
  }
}

// The direction in which a footprint's metal reflexes deepen fastest (a plane through them by
// least squares), in `axis`'s frame; `axis` itself where they hardly deepen (a level tool).
Axis steepest_axis(const std::vector<Place>& cells, const InstrumentFindings& f, const Axis& axis) {
  const Plane plane = reflex_plane(
      cells, f, axis, [&](const Place& c) { return f.mask[c.k] == ColumnKind::shadow; });
  if (!plane.valid) return axis;
  const double g = std::hypot(plane.gx, plane.gy);
  if (!(g > 0.0)) return axis;
  Axis out = axis;
  out.ux = plane.gx / g;
  out.uy = plane.gy / g;
  return out;
}

// A paddle just above the retina: its leading face's A-scans (a short object over a gap) are
// classified, but the A-scans behind them (no long gap beneath) are not, and cut them off from the
// tool. A partly shadowed region ahead of the paddle (its A-scans within kPaddleReachUm of the
// footprint's extreme along the axis, within the paddle's width across it) whose reflexes lie
// between the paddle's middle plane and its front surface (kPaddleOnIlmPx of slack), and above
// the segmented ILM, is that face:
// it joins the footprint and the mask, and so do the clear A-scans between (within the paddle's
// width, from kPaddleReachUm behind the footprint's extreme up to the face's), their reflexes on
// the plane: the segmented ILM there may be the paddle's, not to be taken for the retina's.

void join_paddle_parts(Footprint& fp, const std::vector<const Footprint*>& loose,
                       InstrumentFindings& f, const Surfaces& surfaces, const Axis& principal,
                       std::vector<double>& scratch) {
  if (surfaces.bscans != f.bscans || surfaces.ascans != f.ascans) return;
  const Plane plane = paddle_plane(fp.ascans, f, principal);
  const double g = std::hypot(plane.gx, plane.gy);
  const double half_height = median_half_height(fp.ascans, f, scratch);
  if (!plane.valid || !(g > 0.0) || !(half_height > 0.0)) return;
  Axis axis = principal;
  axis.ux = plane.gx / g;
  axis.uy = plane.gy / g;
  double s_max = -1e300, lo = 1e300, hi = -1e300;
  for (const Place& c : fp.ascans) {
    s_max = std::max(s_max, axis.along(c));
    if (!classified_partial(f, c)) continue;
    lo = std::min(lo, axis.across(c));
    hi = std::max(hi, axis.across(c));
  }
  double face_max = -1e300;
  for (const Footprint* part : loose) {
    const bool on_face = std::all_of(part->ascans.begin(), part->ascans.end(), [&](const Place& c) {
      const double s = axis.along(c), across = axis.across(c);
      const double above = plane.at(axis.x(c), axis.y(c)) - f.reflex_px[c.k];
      // Above the segmented ILM: not speckle inside the retina, which the plane meets further on.
      const bool above_retina = surfaces.state[c.k] == SurfaceState::measured &&
                                f.reflex_px[c.k] + kPaddleOnIlmPx <= surfaces.ilm[c.k];
      return f.columns[c.k] == ColumnKind::partial && above_retina && s > s_max &&
             s <= s_max + kPaddleReachUm && across >= lo && across <= hi &&
             above >= -kPaddleOnIlmPx && above <= half_height + kPaddleOnIlmPx;
    });
    if (!on_face) continue;
    for (const Place& c : part->ascans) {
      f.mask[c.k] = ColumnKind::partial;
      fp.ascans.push_back(c);
      face_max = std::max(face_max, axis.along(c));
    }
  }
  if (face_max == -1e300) return;
  std::uint32_t b_lo = ~0u, b_hi = 0, a_lo = ~0u, a_hi = 0;
  for (const Place& c : fp.ascans) {
    b_lo = std::min(b_lo, c.b);
    b_hi = std::max(b_hi, c.b);
    a_lo = std::min(a_lo, c.a);
    a_hi = std::max(a_hi, c.a);
  }
  for (std::uint32_t b = b_lo; b <= b_hi; ++b) {
    for (std::uint32_t a = a_lo; a <= a_hi; ++a) {
      const Place c = Place(f.index(b, a), b, a, axis.sx, axis.sy);
      const double s = axis.along(c), across = axis.across(c);
      if (f.mask[c.k] != ColumnKind::clear || s < s_max - kPaddleReachUm || s > face_max ||
          across < lo || across > hi) {
        continue;
      }
      f.mask[c.k] = ColumnKind::partial;
      f.reflex_px[c.k] = static_cast<float>(plane.at(axis.x(c), axis.y(c)));
      fp.ascans.push_back(c);
    }
  }
}

InstrumentTip finish_tip(const Footprint& fp, const EndTip& end, const Axis& axis,
                         const VolumeSampling& sampling) {
  const double sx = sampling.ascan_spacing_um, sy = sampling.bscan_spacing_um;
  InstrumentTip tip;
  tip.footprint_ascans = static_cast<std::uint32_t>(fp.ascans.size());
  tip.translucent = end.translucent;
  tip.ascan = end.x / sx;
  tip.bscan = end.y / sy;
  tip.depth_px = end.depth_px;
  tip.x_um = end.x;
  tip.y_um = end.y;
  tip.axis_x = axis.ux;
  tip.axis_y = axis.uy;
  tip.z_um = tip.depth_px * sampling.axial_um_per_px;
  return tip;
}

// A footprint, its principal axis and its end along that axis.
struct Tool {
  Footprint* fp = nullptr;
  Axis principal;
  End whole;
};

// What tip_of works in, kept from call to call.
struct TipBuffers {
  Prongs prongs, bisector_prongs;
  std::vector<double> steepest_along;
  std::vector<Place> near;
  FitBuffers fit;
  std::vector<double> scratch;
};

InstrumentTip tip_of(const Tool& tool, const InstrumentFindings& f, const InstrumentConfig& config,
                     const VolumeSampling& sampling, TipBuffers& buffers) {
  const double sx = sampling.ascan_spacing_um, sy = sampling.bscan_spacing_um;
  const double um_per_px_medium = sampling.axial_um_per_px / config.medium_group_index;
  const Footprint& fp = *tool.fp;
  const Axis& principal = tool.principal;
  const End& whole = tool.whole;
  Axis axis = principal;
  EndTip end;
  if (whole.translucent) {
    end = tip_of_paddle(fp.ascans, f, principal, sx, sy, um_per_px_medium, axis, buffers.scratch);
    return finish_tip(fp, end, axis, sampling);
  }
  const Prongs* prongs = &buffers.prongs;
  prongs_of(whole.cells, whole.along, whole.s_max, buffers.prongs);
  Axis bisector = principal;
  if (prongs->count < 2) {
    // Open jaws whose shaft is out of the field make a V as wide as it is long: its principal
    // axis may run across it. Both jaws deepen towards their ends: the reflexes' steepest
    // direction is the V's bisector.
    const Axis steepest = steepest_axis(fp.ascans, f, principal);
    if (steepest.ux != principal.ux || steepest.uy != principal.uy) {
      std::vector<double>& along = buffers.steepest_along;
      places_along(fp.ascans, steepest, along);
      prongs_of(fp.ascans, along, largest(along), buffers.bisector_prongs);
      if (buffers.bisector_prongs.count >= 2) {
        prongs = &buffers.bisector_prongs;
        bisector = steepest;
      }
    }
  }
  if (prongs->count >= 2) {
    // An open forceps: the tip is the middle of its jaws' ends (instrument_truth.hpp).
    for (std::size_t i = 0; i < prongs->count; ++i) {
      const std::vector<Place>& prong = (*prongs)[i];
      Axis own = axis_of(prong, f, sx, sy);
      if (own.ux * bisector.ux + own.uy * bisector.uy < 0.0) {
        own.ux = -own.ux;
        own.uy = -own.uy;
      }
      const EndTip t = tip_of_end(prong, f, own, sx, sy, um_per_px_medium, buffers.fit);
      end.x += t.x;
      end.y += t.y;
      end.depth_px += t.depth_px;
    }
    const auto n = static_cast<double>(prongs->count);
    end.x /= n;
    end.y /= n;
    end.depth_px /= n;
  } else {
    // The footprint's principal axis leans towards a wider shaft that the field's border cuts:
    // the axis of the end's last kAxisLengthUm, in the same sense, follows the tip's part.
    std::vector<Place>& near = buffers.near;
    near.clear();
    for (std::size_t i = 0; i < whole.cells.size(); ++i) {
      if (whole.along[i] >= whole.s_max - kAxisLengthUm) near.push_back(whole.cells[i]);
    }
    if (near.size() >= kMinEndReflexes) {
      axis = axis_of(near, f, sx, sy);
      if (axis.ux * principal.ux + axis.uy * principal.uy < 0.0) {
        axis.ux = -axis.ux;
        axis.uy = -axis.uy;
      }
    }
    end = tip_of_end(fp.ascans, f, axis, sx, sy, um_per_px_medium, buffers.fit);
  }
  return finish_tip(fp, end, axis, sampling);
}

// A footprint this many times smaller than a tool's, lying along that tool's shaft behind its end,
// is a part of the same tool (part_of_shaft).
constexpr std::size_t kShaftPartRatio = 8;

// Whether `small` is a piece of `large`'s shaft that the classification cut off from it (where a
// pitched shaft rises out of the top of the image, its shadow's edges stay classified, its middle
// does not, and a stretch of an edge comes apart): much smaller, its centre behind `large`'s end
// along `large`'s axis, and no further from that axis than `large`'s own A-scans behind its end
// (its shaft's) reach across it, plus `margin_um`. A small tool's tip under another tool's shaft
// would be taken for a piece of it; beside the shaft or near its end it stays a tool.
bool part_of_shaft(const Tool& small, const Tool& large, double margin_um) {
  if (small.fp->ascans.size() * kShaftPartRatio > large.fp->ascans.size()) return false;
  const Axis& axis = large.principal;
  const double behind_end = large.whole.s_max - 2.0 * kMaxRadiusUm;
  const double dx = small.principal.mx - axis.mx, dy = small.principal.my - axis.my;
  const double along = dx * axis.ux + dy * axis.uy;
  const double across = -dx * axis.uy + dy * axis.ux;
  if (along >= behind_end) return false;  // by the end: maybe a tool of its own
  double reach = -1.0;
  for (const Place& p : large.fp->ascans) {
    if (axis.along(p) < behind_end) reach = std::max(reach, std::abs(axis.across(p)));
  }
  return reach >= 0.0 && std::abs(across) <= reach + margin_um;
}

// Into `open` (all clear): the A-scans classified as masked with at least kMinMaskedNeighbours
// of their 8 neighbours so too. Only the classified ones are looked at (most of a mask is clear).
void clean_mask(const InstrumentFindings& f, ColumnKind* open) {
  for (std::uint32_t b = 0; b < f.bscans; ++b) {
    const ColumnKind* row = &f.columns[f.index(b, 0)];
    for (std::size_t a = next_not_clear(row, 0, f.ascans); a < f.ascans;
         a = next_not_clear(row, a + 1, f.ascans)) {
      if (masked_neighbours(f, b, static_cast<std::int64_t>(a)) >=
          InstrumentFindings::kMinMaskedNeighbours) {
        open[f.index(b, static_cast<std::uint32_t>(a))] = row[a];
      }
    }
  }
}

}  // namespace

struct TipFinder::Buffers {
  // The cleaned mask's A-scans in no footprint yet: all clear between calls (the footprints'
  // search clears every one it reaches, and it reaches all).
  std::vector<ColumnKind> open;
  std::vector<std::uint64_t> stack;
  FootprintPool footprints;
  std::vector<Footprint*> found;
  std::vector<const Footprint*> loose;
  std::vector<Tool> tools;
  std::vector<Place> pending;
  TipBuffers tip;
  // Between locate() and place(): the tool whose shape is next (or, where paddle_waiting, whose
  // axis and end are known and whose paddle waits for the ILM).
  std::size_t next_tool = 0;
  bool paddle_waiting = false;
};

TipFinder::TipFinder() : buffers_(std::make_unique<Buffers>()) {}
TipFinder::~TipFinder() = default;
// A moved-from finder has located nothing (its buffers went with the move).
TipFinder::TipFinder(TipFinder&& other) noexcept
    : buffers_(std::move(other.buffers_)), located_(std::exchange(other.located_, nullptr)) {}
TipFinder& TipFinder::operator=(TipFinder&& other) noexcept {
  buffers_ = std::move(other.buffers_);
  located_ = std::exchange(other.located_, nullptr);
  return *this;
}

void TipFinder::find(InstrumentFindings& findings, const Surfaces& surfaces,
                     const InstrumentConfig& config, const VolumeSampling& sampling) {
  locate(findings, config, sampling);
  place(findings, surfaces, config, sampling);
}

void TipFinder::locate(InstrumentFindings& findings, const InstrumentConfig& config,
                       const VolumeSampling& sampling) {
  Buffers& w = *buffers_;
  located_ = nullptr;
  findings.tips.clear();
  findings.nearest = -1;
  findings.warning = false;
  if (w.open.size() != findings.size()) w.open.assign(findings.size(), ColumnKind::clear);
  clean_mask(findings, w.open.data());
  std::vector<Footprint*>& found = w.found;
  const double sx = sampling.ascan_spacing_um, sy = sampling.bscan_spacing_um;
  find_footprints(findings, config.min_ascans, sx, sy, w.open.data(), w.stack, w.footprints, found,
                  w.loose);
  // The mask keeps the instruments' A-scans only (not a membrane's, a floater's, speckle's).
  std::fill(findings.mask.begin(), findings.mask.end(), ColumnKind::clear);
  for (const Footprint* fp : found) {
    for (const Place& p : fp->ascans) findings.mask[p.k] = findings.columns[p.k];
  }
  // Grown only: a Tool keeps its buffers from call to call.
  if (w.tools.size() < found.size()) w.tools.resize(found.size());
  w.next_tool = 0;
  w.paddle_waiting = false;
  if (shape_tools(findings, nullptr, sx, sy)) tips_of_tools(findings, config, sampling);
  located_ = &findings;
}

void TipFinder::place(InstrumentFindings& findings, const Surfaces& surfaces,
                      const InstrumentConfig& config, const VolumeSampling& sampling) {
  if (located_ != &findings) {
    throw std::logic_error(
        "instruments: TipFinder::place() for findings that locate() did not locate last");
  }
  located_ = nullptr;
  Buffers& w = *buffers_;
  if (w.paddle_waiting) {
    shape_tools(findings, &surfaces, sampling.ascan_spacing_um, sampling.bscan_spacing_um);
    tips_of_tools(findings, config, sampling);
  }
  for (InstrumentTip& tip : findings.tips) {
    const SurfaceAt at = surfaces_at(findings, surfaces, tip.bscan, tip.ascan, sampling);
    tip.source = at.source;
    tip.ilm_px = at.ilm;
    tip.rpe_px = at.rpe;
    if (at.source != DistanceSource::none) {
      tip.to_ilm_um = (at.ilm - tip.depth_px) * sampling.axial_um_per_px;
      tip.to_rpe_um = (at.rpe - tip.depth_px) * sampling.axial_um_per_px;
    }
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

bool TipFinder::shape_tools(InstrumentFindings& findings, const Surfaces* surfaces, double sx,
                            double sy) {
  Buffers& w = *buffers_;
  for (; w.next_tool < w.found.size(); ++w.next_tool) {
    Footprint& fp = *w.found[w.next_tool];
    Tool& tool = w.tools[w.next_tool];
    if (!w.paddle_waiting) {
      tool.fp = &fp;
      tool.principal = axis_of(fp.ascans, findings, sx, sy);
      end_of(fp.ascans, findings, tool.principal, std::min(sx, sy), tool.whole);
    }
    if (!tool.whole.translucent) continue;
    // A paddle grows onto the retina's ILM (and the later tools see the mask it grew).
    w.paddle_waiting = surfaces == nullptr;
    if (w.paddle_waiting) return false;
    extend_paddle(fp, findings, *surfaces, tool.principal, w.pending, w.tip.scratch);
    join_paddle_parts(fp, w.loose, findings, *surfaces, tool.principal, w.tip.scratch);
  }
  return true;
}

void TipFinder::tips_of_tools(InstrumentFindings& findings, const InstrumentConfig& config,
                              const VolumeSampling& sampling) {
  Buffers& w = *buffers_;
  std::vector<Tool>& tools = w.tools;
  // Pieces of a larger tool's shaft are no tools of their own (they stay in the mask: the tool's
  // shadow). Then the largest kMaxInstruments.
  const double shaft_margin_um =
      2.0 * std::max(sampling.ascan_spacing_um, sampling.bscan_spacing_um);
  std::size_t kept = 0;
  for (std::size_t i = 0; i < w.found.size(); ++i) {
    bool piece = false;
    for (std::size_t j = 0; j < kept && !piece; ++j) {
      piece = part_of_shaft(tools[i], tools[j], shaft_margin_um);
    }
    if (piece) continue;
    if (kept != i) std::swap(tools[kept], tools[i]);  // their buffers swapped, none allocated
    ++kept;
  }
  const std::size_t tool_count = std::min(kept, InstrumentFindings::kMaxInstruments);
  for (std::size_t i = 0; i < tool_count; ++i) {
    findings.tips.push_back(tip_of(tools[i], findings, config, sampling, w.tip));
  }
}

void find_tips(InstrumentFindings& findings, const Surfaces& surfaces,
               const InstrumentConfig& config, const VolumeSampling& sampling) {
  TipFinder().find(findings, surfaces, config, sampling);
}

}  // namespace ioct::gpu::instruments
