#include "instant_motion_tracking/core/anchor/time_offset.h"

#include <algorithm>
#include <cmath>
#include <vector>

namespace imt {
namespace {

// Pearson correlation of a and b (-1 when either is constant).
double correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = a.size();
  if (n < 2) return -1;
  double ma = 0, mb = 0;
  for (size_t i = 0; i < n; ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= n;
  mb /= n;
  double sab = 0, saa = 0, sbb = 0;
  for (size_t i = 0; i < n; ++i) {
    sab += (a[i] - ma) * (b[i] - mb);
    saa += (a[i] - ma) * (a[i] - ma);
    sbb += (b[i] - mb) * (b[i] - mb);
  }
  if (!(saa > 0 && sbb > 0)) return -1;
  return sab / std::sqrt(saa * sbb);
}

}  // namespace

void TimeOffsetEstimator::add(double t0, double t1, double angle) {
  if (!std::isfinite(t0) || !std::isfinite(t1) || !(t1 > t0) || !std::isfinite(angle) || angle < 0) return;
  turns_.push_back({t0, t1, angle});
  while (turns_.size() > options_.max_turns) turns_.pop_front();
}

TimeOffsetFit TimeOffsetEstimator::fit(const std::function<bool(double, double, double*)>& gyroAngle) const {
  TimeOffsetFit out;
  const Options& o = options_;
  const int steps = static_cast<int>(std::lround(o.max_offset / 0.001));
  // The intervals the gyro covers at every candidate offset: the same set
  // for each, so the correlations compare.
  std::vector<const Turn*> used;
  for (const Turn& t : turns_) {
    double a;
    if (gyroAngle(t.t0 - o.max_offset, t.t1 - o.max_offset, &a) &&
        gyroAngle(t.t0 + o.max_offset, t.t1 + o.max_offset, &a))
      used.push_back(&t);
  }
  out.turns = static_cast<int>(used.size());
  if (out.turns < o.min_turns) return out;
  std::vector<double> cam(used.size()), gyro(used.size());
  double mean = 0, var = 0;
  for (size_t i = 0; i < used.size(); ++i) mean += cam[i] = used[i]->angle;
  mean /= cam.size();
  for (double c : cam) var += (c - mean) * (c - mean);
  if (!(std::sqrt(var / cam.size()) >= o.min_spread)) return out;  // no varying turns to align
  // The changes of the angle from one interval to the next (the turn's
  // acceleration): the slow part of the motion, which any offset matches
  // about as well, and what the camera's translation adds to its turns
  // (steady), drop out; the sharp changes that show the offset stay.
  std::vector<std::pair<size_t, size_t>> steps_used;  // consecutive intervals (i - 1, i)
  for (size_t i = 1; i < used.size(); ++i)
    if (std::abs(used[i]->t0 - used[i - 1]->t1) < 1e-6) steps_used.emplace_back(i - 1, i);
  const bool by_change = steps_used.size() >= static_cast<size_t>(o.min_turns) / 2;
  std::vector<double> cam_d, gyro_d;
  if (by_change) {
    for (const auto& [a, b] : steps_used) cam_d.push_back(cam[b] - cam[a]);
    gyro_d.resize(cam_d.size());
  }
  // Correlation at offset k ms (memoised): every 4 ms over the range, then
  // every ms around the best.
  std::vector<double> score(2 * steps + 1, -2);
  auto at = [&](int k) {
    double& s = score[k + steps];
    if (s > -2) return s;
    const double d = k * 0.001;
    bool ok = true;
    for (size_t i = 0; i < used.size() && ok; ++i) ok = gyroAngle(used[i]->t0 + d, used[i]->t1 + d, &gyro[i]);
    if (ok && by_change) {
      for (size_t j = 0; j < steps_used.size(); ++j) gyro_d[j] = gyro[steps_used[j].second] - gyro[steps_used[j].first];
      s = correlation(cam_d, gyro_d);
    } else {
      s = ok ? correlation(cam, gyro) : -1;
    }
    return s;
  };
  int best = 0;
  for (int k = -steps; k <= steps; k += 4)
    if (at(k) > at(best)) best = k;
  for (int k = std::max(-steps, best - 3); k <= std::min(steps, best + 3); ++k)
    if (at(k) > at(best)) best = k;
  out.at_zero = at(0);
  out.correlation = at(best);
  double offset = best * 0.001;
  if (best > -steps && best < steps) {
    const double l = at(best - 1), c = at(best), r = at(best + 1), den = l - 2 * c + r;
    if (den < 0) offset += 0.001 * std::clamp(0.5 * (l - r) / den, -0.5, 0.5);
  }
  out.offset = offset;
  // A peak on the range's edge may lie beyond it.
  out.found = best > -steps && best < steps && out.correlation >= o.min_correlation;
  return out;
}

}  // namespace imt
