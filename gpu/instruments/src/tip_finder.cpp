#include "ioct/gpu/instruments/tip_finder.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
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

struct Footprint {
  std::vector<std::uint32_t> ascans;  // indices into the mask
};

std::vector<Footprint> footprints(const InstrumentFindings& f, std::uint32_t min_ascans) {
  std::vector<std::uint8_t> seen(f.size(), 0);
  std::vector<Footprint> out;
  std::vector<std::uint32_t> stack;
  for (std::uint32_t start = 0; start < f.size(); ++start) {
    if (seen[start] || f.mask[start] == ColumnKind::clear) continue;
    Footprint fp;
    seen[start] = 1;
    stack.assign(1, start);
    while (!stack.empty()) {
      const std::uint32_t k = stack.back();
      stack.pop_back();
      fp.ascans.push_back(k);
      const std::int64_t b = k / f.ascans;
      const std::int64_t a = k % f.ascans;
      for (std::int64_t db = -1; db <= 1; ++db) {
        for (std::int64_t da = -1; da <= 1; ++da) {
          const std::int64_t nb = b + db, na = a + da;
          if (nb < 0 || na < 0 || nb >= f.bscans || na >= f.ascans) continue;
          const auto n = static_cast<std::uint32_t>(nb * f.ascans + na);
          if (seen[n] || f.mask[n] == ColumnKind::clear) continue;
          seen[n] = 1;
          stack.push_back(n);
        }
      }
    }
    // Every tool has metal (the scraper's paddle sits on a metal shaft): a footprint only
    // partly shadowed is a membrane or a floater lifted off the retina.
    const auto metal = std::count_if(fp.ascans.begin(), fp.ascans.end(), [&](std::uint32_t k) {
      return f.mask[k] == ColumnKind::shadow;
    });
    if (fp.ascans.size() >= min_ascans && static_cast<std::size_t>(metal) >= min_ascans) {
      out.push_back(std::move(fp));
    }
  }
  std::stable_sort(out.begin(), out.end(), [](const Footprint& x, const Footprint& y) {
    return x.ascans.size() > y.ascans.size();
  });
  return out;
}

// A surface (ILM or RPE, px) at fractional (bscan, ascan) from the nearest unshadowed, measured
// A-scans; `own` says whether the nearest A-scan itself was usable.
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
    std::int64_t hi = lo + 1;
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

InstrumentTip tip_of(const Footprint& fp, const InstrumentFindings& f,
                     const InstrumentConfig& config, const VolumeSampling& sampling) {
  const double sx = sampling.ascan_spacing_um, sy = sampling.bscan_spacing_um;
  // Centroid and covariance in um.
  double mx = 0.0, my = 0.0;
  for (const std::uint32_t k : fp.ascans) {
    mx += static_cast<double>(k % f.ascans) * sx;
    my += static_cast<double>(k / f.ascans) * sy;
  }
  const double n = static_cast<double>(fp.ascans.size());
  mx /= n;
  my /= n;
  double cxx = 0.0, cxy = 0.0, cyy = 0.0;
  for (const std::uint32_t k : fp.ascans) {
    const double dx = static_cast<double>(k % f.ascans) * sx - mx;
    const double dy = static_cast<double>(k / f.ascans) * sy - my;
    cxx += dx * dx;
    cxy += dx * dy;
    cyy += dy * dy;
  }
  // The principal axis of the 2 x 2 covariance.
  const double angle = 0.5 * std::atan2(2.0 * cxy, cxx - cyy);
  double ux = std::cos(angle), uy = std::sin(angle);
  const auto along = [&](std::uint32_t k) {
    return (static_cast<double>(k % f.ascans) * sx - mx) * ux +
           (static_cast<double>(k / f.ascans) * sy - my) * uy;
  };
  const auto across = [&](std::uint32_t k) {
    return -(static_cast<double>(k % f.ascans) * sx - mx) * uy +
           (static_cast<double>(k / f.ascans) * sy - my) * ux;
  };
  // Orientation: the tip away from the border the shaft crosses; else towards the deeper reflex.
  double border_sum = 0.0;
  std::size_t border = 0;
  double s_sum = 0.0, z_sum = 0.0, sz_sum = 0.0, ss_sum = 0.0;
  for (const std::uint32_t k : fp.ascans) {
    const std::uint32_t b = k / f.ascans, a = k % f.ascans;
    const double s = along(k);
    if (a == 0 || b == 0 || a + 1 == f.ascans || b + 1 == f.bscans) {
      border_sum += s;
      ++border;
    }
    s_sum += s;
    z_sum += f.reflex_px[k];
    sz_sum += s * f.reflex_px[k];
    ss_sum += s * s;
  }
  const double slope = (sz_sum - s_sum * z_sum / n) / std::max(1e-9, ss_sum - s_sum * s_sum / n);
  if (border > 0 ? border_sum > 0.0 : slope < 0.0) {
    ux = -ux;
    uy = -uy;
  }
  double s_max = -1e300;
  for (const std::uint32_t k : fp.ascans) s_max = std::max(s_max, along(k));
  // Everything below looks at the end only: the A-scans within the largest radius of it.
  std::vector<std::uint32_t> end;
  for (const std::uint32_t k : fp.ascans) {
    if (along(k) >= s_max - 2.0 * kMaxRadiusUm) end.push_back(k);
  }
  // The end's rim: the A-scans within one lateral sample of the extreme, and their offset
  // across the axis.
  const double rim = std::min(sx, sy);
  double rim_across = 0.0;
  std::size_t rim_count = 0;
  for (const std::uint32_t k : end) {
    if (along(k) >= s_max - rim) {
      rim_across += across(k);
      ++rim_count;
    }
  }
  rim_across /= static_cast<double>(rim_count);
  const bool translucent = [&] {
    std::size_t partial = 0, shadow = 0;
    for (const std::uint32_t k : end) {
      if (along(k) < s_max - 2.0 * rim) continue;
      (f.mask[k] == ColumnKind::partial ? partial : shadow) += 1;
    }
    return partial > shadow;
  }();
  // The rounded end (a capsule's cap, the shape of every metal tool's end): a sphere of radius r
  // whose rim is the footprint's extreme. In front of its centre every reflex lies on it:
  // z = zc - sqrt(r^2 - d^2) (um of the medium). Tried for every r, the one whose reflexes agree
  // best on the centre's depth zc wins.
  const double um_per_px_medium = sampling.axial_um_per_px / config.medium_group_index;
  struct Fit {
    double radius = 0.0, center_px = 0.0, cost = 1e300;
  } best_fit;
  if (!translucent) {
    // The end's shadowed A-scans, nearest the extreme first: a sphere of radius r sees only those
    // in front of its centre, a prefix of this list that grows with r.
    struct Reflex {
      double s, dc, z;
    };
    std::vector<Reflex> reflexes;
    for (const std::uint32_t k : end) {
      if (f.mask[k] == ColumnKind::shadow) {
        reflexes.push_back({along(k), across(k) - rim_across, f.reflex_px[k]});
      }
    }
    std::sort(reflexes.begin(), reflexes.end(),
              [](const Reflex& x, const Reflex& y) { return x.s > y.s; });
    for (double r = 2.0 * rim; r <= kMaxRadiusUm; r += 2.0) {
      const double cs = s_max + 0.5 * rim - r;
      double sum = 0.0, sum2 = 0.0;
      std::size_t count = 0;
      for (const Reflex& reflex : reflexes) {
        if (reflex.s < cs) break;
        const double ds = reflex.s - cs;
        const double d2 = ds * ds + reflex.dc * reflex.dc;
        if (d2 >= r * r) continue;
        const double zc = reflex.z + std::sqrt(r * r - d2) / um_per_px_medium;
        sum += zc;
        sum2 += zc * zc;
        ++count;
      }
      if (count < 3) continue;
      const double mean = sum / static_cast<double>(count);
      const double variance = std::max(0.0, sum2 / static_cast<double>(count) - mean * mean);
      // The footprint must match the sphere's: the share of A-scans in front of the centre, near
      // the end, that are masked outside the sphere's disc or clear inside it.
      const double reach = r + rim;
      const double cx = mx + cs * ux - rim_across * uy, cy = my + cs * uy + rim_across * ux;
      const std::int64_t a_lo = std::max<std::int64_t>(0, std::lround((cx - reach) / sx));
      const std::int64_t a_hi =
          std::min<std::int64_t>(f.ascans - 1, std::lround((cx + reach) / sx));
      const std::int64_t b_lo = std::max<std::int64_t>(0, std::lround((cy - reach) / sy));
      const std::int64_t b_hi =
          std::min<std::int64_t>(f.bscans - 1, std::lround((cy + reach) / sy));
      std::size_t cells = 0, mismatches = 0;
      for (std::int64_t b = b_lo; b <= b_hi; ++b) {
        const double dy = static_cast<double>(b) * sy - cy;
        const double dy_along = dy * uy, dy2 = dy * dy;
        if (dy2 > reach * reach) continue;
        const ColumnKind* row = &f.mask[f.index(static_cast<std::uint32_t>(b), 0)];
        // Only the row's chord of the disc (a cell wider on each side: the tests below decide).
        const double half_chord = std::sqrt(reach * reach - dy2);
        const std::int64_t a_from =
            std::max<std::int64_t>(a_lo, static_cast<std::int64_t>((cx - half_chord) / sx) - 1);
        const std::int64_t a_to =
            std::min<std::int64_t>(a_hi, static_cast<std::int64_t>((cx + half_chord) / sx) + 1);
        for (std::int64_t a = a_from; a <= a_to; ++a) {
          const double dx = static_cast<double>(a) * sx - cx;
          if (dx * ux + dy_along < 0.0) continue;
          const double d2 = dx * dx + dy2;
          if (d2 > reach * reach) continue;
          const bool inside = d2 < r * r;
          const bool masked = row[a] != ColumnKind::clear;
          ++cells;
          mismatches += inside != masked ? 1 : 0;
        }
      }
      const double mismatch =
          cells > 0 ? static_cast<double>(mismatches) / static_cast<double>(cells) : 1.0;
      const double cost = variance / kDepthSpreadPx2 + mismatch / kFootprintMismatch;
      if (cost < best_fit.cost) best_fit = {r, mean, cost};
    }
  }
  const double radius_um = best_fit.cost < 1e300 ? best_fit.radius : 0.0;
  const double tip_s = s_max + 0.5 * rim - radius_um;
  const double tip_x = mx + tip_s * ux - rim_across * uy;
  const double tip_y = my + tip_s * uy + rim_across * ux;
  InstrumentTip tip;
  tip.footprint_ascans = static_cast<std::uint32_t>(fp.ascans.size());
  tip.translucent = translucent;
  tip.ascan = tip_x / sx;
  tip.bscan = tip_y / sy;
  if (best_fit.cost < 1e300) {
    tip.depth_px = best_fit.center_px;
  } else {
    // A flat (translucent) end, or too few reflexes for a sphere: the reflex nearest to the tip
    // (a translucent tool's is the middle of its front and back surface).
    double nearest = 1e300;
    for (const std::uint32_t k : end) {
      if (f.mask[k] == ColumnKind::clear) continue;
      const double dx = static_cast<double>(k % f.ascans) * sx - tip_x;
      const double dy = static_cast<double>(k / f.ascans) * sy - tip_y;
      if (dx * dx + dy * dy < nearest) {
        nearest = dx * dx + dy * dy;
        tip.depth_px = f.reflex_px[k];
      }
    }
  }
  tip.x_um = tip_x;
  tip.y_um = tip_y;
  tip.axis_x = ux;
  tip.axis_y = uy;
  tip.z_um = tip.depth_px * sampling.axial_um_per_px;
  return tip;
}

void clean_mask(InstrumentFindings& f) {
  for (std::int64_t b = 0; b < f.bscans; ++b) {
    for (std::int64_t a = 0; a < f.ascans; ++a) {
      const std::size_t k = f.index(static_cast<std::uint32_t>(b), static_cast<std::uint32_t>(a));
      f.mask[k] = ColumnKind::clear;
      if (f.columns[k] == ColumnKind::clear) continue;
      int neighbours = 0;
      for (std::int64_t nb = std::max<std::int64_t>(0, b - 1);
           nb <= std::min<std::int64_t>(f.bscans - 1, b + 1); ++nb) {
        for (std::int64_t na = std::max<std::int64_t>(0, a - 1);
             na <= std::min<std::int64_t>(f.ascans - 1, a + 1); ++na) {
          if ((nb != b || na != a) &&
              f.columns[f.index(static_cast<std::uint32_t>(nb), static_cast<std::uint32_t>(na))] !=
                  ColumnKind::clear) {
            ++neighbours;
          }
        }
      }
      if (neighbours >= InstrumentFindings::kMinMaskedNeighbours) f.mask[k] = f.columns[k];
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
    for (const std::uint32_t k : fp.ascans) findings.mask[k] = findings.columns[k];
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
