// SPDX-License-Identifier: BSD-3-Clause
// Offset calibration x = b1·v + b2 (docs/method.md §11.4): each run registered onto the known profile by PCL's
// ICP (translation along x and a height offset; a height tilt too against a LiDAR map), checked by
// cross-correlation, then a line over the runs.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>

#include <pcl/point_types.h>
#include <pcl/registration/icp.h>
#include <pcl/search/kdtree.h>
#include <pcl/registration/transformation_estimation_lm.h>
#include <pcl/registration/warp_point_rigid.h>

#include "core/text.hpp"
#include "roadpreview/range_sensor/range_sensor.hpp"

namespace roadpreview {
namespace {

using Point = pcl::PointXYZ;
using Cloud = pcl::PointCloud<Point>;

constexpr double kReferenceStep_m = 0.002;  // the reference is densified to this step for the closest points
constexpr int kStarts = 11;                 // ICP starts spread over guess ± search (closest points are local)
constexpr std::size_t kMaxIcpSamples = 2000;  // more add time, not precision (the residual check uses all)
constexpr double kDistinctSpeeds = 0.1;     // speeds must span this fraction of the largest

// ICP's only free parameters: a shift along x, a height offset and, for a reference whose datum leans against
// the sensor's heights, a height tilt about the run's mean x (z + offset + tilt·(x − x̄)). A fused LiDAR map's
// levelling leans (2.6 mm/m on the simulated road), which a shift alone absorbed as a biased x (b2 off by 10 cm);
// on an exact reference the tilt is left out, as it trades off with the shift on asymmetric features.
class WarpShiftXZ : public pcl::registration::WarpPointRigid<Point, Point, float> {
public:
    WarpShiftXZ(bool tilt, float x_mean) : WarpPointRigid(tilt ? 3 : 2), x_mean_(x_mean) {
        transform_matrix_.setIdentity();
    }
    void setParam(const VectorX& p) override {
        transform_matrix_.setIdentity();
        transform_matrix_(0, 3) = p[0];
        const float tilt = p.size() > 2 ? p[2] : 0.0f;
        transform_matrix_(2, 0) = tilt;
        transform_matrix_(2, 3) = p[1] - tilt * x_mean_;
    }

private:
    float x_mean_;
};

// Linear interpolation of the reference at x (NaN outside it).
struct Reference {
    const std::vector<double>& x;
    const std::vector<double>& z;
    double at(double q) const {
        if (!(q >= x.front() && q <= x.back())) return std::numeric_limits<double>::quiet_NaN();
        const auto hi = std::min<std::size_t>(static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(),
            q) - x.begin()),
                                              x.size() - 1);
        const double w = (q - x[hi - 1]) / (x[hi] - x[hi - 1]);
        return z[hi - 1] + w * (z[hi] - z[hi - 1]);
    }
    double slope(double q) const { return (at(q
        + 0.5 * kReferenceStep_m) - at(q - 0.5 * kReferenceStep_m)) / kReferenceStep_m; }
};

// Heights are scaled so the reference's RMS slope is about 1: closest points then carry x information.
double height_scale(const Reference& ref) {
    double sum = 0.0;
    std::size_t n = 0;
    for (double q = ref.x.front() + kReferenceStep_m; q < ref.x.back() - kReferenceStep_m; q += 10 * kReferenceStep_m) {
        const double g = ref.slope(q);
        sum += g * g;
        ++n;
    }
    const double rms = n ? std::sqrt(sum / static_cast<double>(n)) : 0.0;
    return std::clamp(rms > 0 ? 1.0 / rms : 1.0, 1.0, 1000.0);
}

Cloud::Ptr cloud_of(const std::vector<double>& x, const std::vector<double>& z, double scale) {
    Cloud::Ptr c(new Cloud);
    for (std::size_t i = 0; i < x.size(); ++i)
        c->push_back(Point(static_cast<float>(x[i]), 0.0f, static_cast<float>(z[i] * scale)));
    return c;
}

// The reference as closest-point targets no further apart than kTargetSpacing along the scaled curve: on steep
// edges a fixed x step leaves gaps that pull the registration towards the denser side.
Cloud::Ptr dense_reference(const Reference& ref, double scale) {
    constexpr double kTargetSpacing = 0.0005;
    std::vector<double> x, z;
    for (double q = ref.x.front(); q <= ref.x.back();) {
        x.push_back(q);
        z.push_back(ref.at(q));
        const double g = scale * ref.slope(q + 0.5 * kReferenceStep_m);
        q += std::isfinite(g) ? std::min(kReferenceStep_m, kTargetSpacing / std::sqrt(1.0 + g * g)) : kReferenceStep_m;
    }
    return cloud_of(x, z, scale);
}

double median_of(std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
    return v[v.size() / 2];
}

// Pearson correlation of the samples' heights with the reference shifted by `lag` (samples off it skipped); with
// `detrend`, the partial correlation given x: a reference leaning against the samples does not move the peak.
double correlation(const std::vector<double>& x, const std::vector<double>& z, const Reference& ref, double lag,
                   bool detrend) {
    double n = 0, sa = 0, sb = 0, sx = 0, saa = 0, sbb = 0, sab = 0, sxx = 0, sxa = 0, sxb = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double r = ref.at(x[i] + lag);
        if (std::isnan(r)) continue;
        n += 1;
        sa += z[i], sb += r, sx += x[i];
        saa += z[i] * z[i], sbb += r * r, sab += z[i] * r;
        sxx += x[i] * x[i], sxa += x[i] * z[i], sxb += x[i] * r;
    }
    if (n < 3) return -1.0;
    const double va = saa - sa * sa / n, vb = sbb - sb * sb / n, cab = sab - sa * sb / n;
    if (!(va > 0 && vb > 0)) return -1.0;
    const double rab = cab / std::sqrt(va * vb);
    const double vx = sxx - sx * sx / n;
    if (!detrend || !(vx > 0)) return rab;
    const double rxa = (sxa - sx * sa / n) / std::sqrt(vx * va), rxb = (sxb - sx * sb / n) / std::sqrt(vx * vb);
    const double den = (1.0 - rxa * rxa) * (1.0 - rxb * rxb);
    return den > 0 ? (rab - rxa * rxb) / std::sqrt(den) : -1.0;
}

// The lag of the correlation's peak on a grid of the reference step, refined by a parabola through its neighbours.
double xcorr_shift(const std::vector<double>& x, const std::vector<double>& z, const Reference& ref, double guess,
                   double search, bool detrend) {
    const int k = static_cast<int>(std::ceil(search / kReferenceStep_m));
    std::vector<double> c(static_cast<std::size_t>(2 * k + 1));
    for (int i = -k; i <= k; ++i)
        c[static_cast<std::size_t>(i + k)] = correlation(x, z, ref, guess + i * kReferenceStep_m, detrend);
    const auto best = static_cast<std::size_t>(std::max_element(c.begin(), c.end()) - c.begin());
    double frac = 0.0;
    if (best > 0 && best + 1 < c.size()) {
        const double den = c[best - 1] - 2 * c[best] + c[best + 1];
        if (den < 0) frac = 0.5 * (c[best - 1] - c[best + 1]) / den;
    }
    return guess + (static_cast<double>(best) - k + frac) * kReferenceStep_m;
}

struct IcpFit {
    double shift = 0.0, z_offset = 0.0, tilt = 0.0, x_mean = 0.0, fitness = std::numeric_limits<double>::infinity();
    // A sample's height residual over the reference: NaN off it.
    double residual(double x, double z, const Reference& ref) const {
        return z + z_offset + tilt * (x - x_mean) - ref.at(x + shift);
    }
};

// Mean squared height residual of the samples over the reference, registered by `fit`.
double height_mse(const std::vector<double>& x, const std::vector<double>& z, const Reference& ref,
                  const IcpFit& fit) {
    double sse = 0.0;
    std::size_t n = 0;
    for (std::size_t i = 0; i < x.size(); ++i) {
        const double r = fit.residual(x[i], z[i], ref);
        if (std::isnan(r)) continue;
        sse += r * r;
        ++n;
    }
    return n ? sse / static_cast<double>(n) : std::numeric_limits<double>::infinity();
}

IcpFit icp_from(const Cloud::Ptr& source, const Cloud::Ptr& target, const pcl::search::KdTree<Point>::Ptr& tree,
                double start, double z0, bool tilt, double x_mean, double scale, double max_corr) {
    pcl::IterativeClosestPoint<Point, Point> icp;
    icp.setSearchMethodTarget(tree, true);  // one tree for every start
    auto estimation = pcl::make_shared<pcl::registration::TransformationEstimationLM<Point, Point, float>>();
    estimation->setWarpFunction(pcl::make_shared<WarpShiftXZ>(tilt, static_cast<float>(x_mean)));
    icp.setTransformationEstimation(estimation);
    icp.setInputSource(source);
    icp.setInputTarget(target);
    icp.setMaxCorrespondenceDistance(max_corr);
    icp.setMaximumIterations(50);
    icp.setTransformationEpsilon(1e-12);
    icp.setEuclideanFitnessEpsilon(1e-14);
    Eigen::Matrix4f guess = Eigen::Matrix4f::Identity();
    guess(0, 3) = static_cast<float>(start);
    guess(2, 3) = static_cast<float>(z0 * scale);
    Cloud aligned;
    icp.align(aligned, guess);
    IcpFit fit;
    if (!icp.hasConverged()) return fit;
    fit.fitness = 0.0;
    const Eigen::Matrix4f T = icp.getFinalTransformation();
    fit.shift = T(0, 3);
    fit.tilt = T(2, 0) / scale;
    fit.x_mean = x_mean;
    fit.z_offset = (T(2, 3) + T(2, 0) * static_cast<float>(x_mean)) / scale;
    return fit;
}

// ICP starts over the guess ± the search: a search that is no distance, or beyond any sensor's reach, is a mistake.
void check_search(double search_m) {
    if (!(search_m > 0.0 && search_m <= 100.0))
        throw std::invalid_argument("the shift search must be in (0, 100] m, got " + number_text(search_m) + " m");
}

}  // namespace

RunShift register_run(const std::vector<double>& x_m, const std::vector<double>& z_m,
                      const std::vector<double>& ref_x_m, const std::vector<double>& ref_z_m, double guess_m,
                      double search_m, bool fit_tilt) {
    // The reference sizes the work: it is densified to 0.5 mm.
    constexpr double kMaxReferenceSpanM = 1000.0;
    check_search(search_m);
    if (!std::isfinite(guess_m)) throw std::invalid_argument("the shift's first guess must be finite");
    if (ref_x_m.size() < 2 || ref_x_m.size() != ref_z_m.size())
        throw std::invalid_argument("the reference profile needs 2 or more (x, z) points of equal count");
    for (std::size_t i = 0; i < ref_x_m.size(); ++i)
        if (!std::isfinite(ref_x_m[i]) || !std::isfinite(ref_z_m[i]) || (i > 0 && !(ref_x_m[i] > ref_x_m[i - 1])))
            throw std::invalid_argument("the reference profile's x must increase and its x and z be finite (row "
                + std::to_string(i) + ")");
    if (!(ref_x_m.back() - ref_x_m.front() <= kMaxReferenceSpanM))
        throw std::invalid_argument("the reference profile spans " + number_text(ref_x_m.back() - ref_x_m.front()) +
                                    " m; at most 1000 m (a bench track, or the map along a run)");
    if (x_m.size() != z_m.size())
        throw std::invalid_argument("a run's x and z differ in length (" + std::to_string(x_m.size()) + " and " +
                                    std::to_string(z_m.size()) + ")");
    for (std::size_t i = 0; i < x_m.size(); ++i)
        if (!std::isfinite(x_m[i]) || !std::isfinite(z_m[i]))
            throw std::invalid_argument("a run's sample " + std::to_string(i) + " is not finite");
    if (x_m.size() < 10) throw std::invalid_argument("a run needs at least 10 samples, got "
        + std::to_string(x_m.size()));
    const Reference ref{ref_x_m, ref_z_m};
    const double scale = height_scale(ref);
    const Cloud::Ptr target = dense_reference(ref, scale);
    const std::size_t stride = (x_m.size() + kMaxIcpSamples - 1) / kMaxIcpSamples;
    std::vector<double> x_icp, z_icp;
    for (std::size_t i = 0; i < x_m.size(); i += stride) {
        x_icp.push_back(x_m[i]);
        z_icp.push_back(z_m[i]);
    }
    const Cloud::Ptr source = cloud_of(x_icp, z_icp, scale);
    const double x_mean = std::accumulate(x_icp.begin(), x_icp.end(), 0.0) / static_cast<double>(x_icp.size());
    std::vector<double> on_ref;
    for (std::size_t i = 0; i < x_m.size(); ++i)
        if (!std::isnan(ref.at(x_m[i] + guess_m))) on_ref.push_back(ref.at(x_m[i] + guess_m) - z_m[i]);
    if (on_ref.size() < 10) throw std::invalid_argument("the run's samples do not lie over the reference profile");
    const double z0 = median_of(on_ref);
    pcl::search::KdTree<Point>::Ptr tree(new pcl::search::KdTree<Point>);
    tree->setInputCloud(target);
    // The best start by the height residual over all samples: ICP's own fitness ignores samples beyond the
    // correspondence distance and so favours alignments that push the slopes out of reach.
    IcpFit best;
    for (int k = 0; k < kStarts; ++k) {
        const double start = guess_m + search_m * (2.0 * k / (kStarts - 1) - 1.0);
        IcpFit fit = icp_from(source, target, tree, start, z0, fit_tilt, x_mean, scale,
                              2.0 * search_m / (kStarts - 1));
        if (std::isfinite(fit.fitness)) fit.fitness = height_mse(x_m, z_m, ref, fit);
        if (fit.fitness < best.fitness) best = fit;
    }
    if (!std::isfinite(best.fitness)) throw std::invalid_argument("ICP did not converge for this run");
    RunShift out;
    out.shift_m = best.shift;
    out.z_offset_m = best.z_offset;
    double sse = 0.0, leverage = 0.0;
    for (std::size_t i = 0; i < x_m.size(); ++i) {
        const double r = best.residual(x_m[i], z_m[i], ref);
        if (std::isnan(r)) continue;
        sse += r * r;
        const double g = ref.slope(x_m[i] + best.shift);
        if (std::isfinite(g)) leverage += g * g;
        ++out.samples;
    }
    out.rms_m = std::sqrt(sse / std::max<double>(1.0, static_cast<double>(out.samples)));
    out.shift_sigma_m = leverage > 0 ? out.rms_m / std::sqrt(leverage) : std::numeric_limits<double>::infinity();
    out.xcorr_shift_m = xcorr_shift(x_m, z_m, ref, guess_m, search_m, fit_tilt);
    return out;
}

namespace {

// Weighted least squares of y = b1·v + b2 (weights 1/σ²; equal when σ is 0), with standard errors
// scaled by the reduced χ² when there are more runs than parameters and it exceeds 1.
void fit_offset_line(const std::vector<double>& v, const std::vector<double>& y, const std::vector<double>& sigma,
                     double& b1, double& b2, double* b1_sigma, double* b2_sigma) {
    double sw = 0, swv = 0, swvv = 0, swy = 0, swvy = 0;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const double w = sigma[i] > 0 && std::isfinite(sigma[i]) ? 1.0 / (sigma[i] * sigma[i]) : 1.0;
        sw += w;
        swv += w * v[i];
        swvv += w * v[i] * v[i];
        swy += w * y[i];
        swvy += w * v[i] * y[i];
    }
    const double det = sw * swvv - swv * swv;
    b1 = (sw * swvy - swv * swy) / det;
    b2 = (swvv * swy - swv * swvy) / det;
    if (!b1_sigma) return;
    double chi2 = 0.0;
    for (std::size_t i = 0; i < v.size(); ++i) {
        const double w = sigma[i] > 0 && std::isfinite(sigma[i]) ? 1.0 / (sigma[i] * sigma[i]) : 1.0;
        chi2 += w * std::pow(y[i] - b1 * v[i] - b2, 2);
    }
    const double factor = v.size() > 2 ? std::max(1.0, chi2 / static_cast<double>(v.size() - 2)) : 1.0;
    *b1_sigma = std::sqrt(factor * sw / det);
    *b2_sigma = std::sqrt(factor * swvv / det);
}

}  // namespace

OffsetCalibration calibrate_offset(const std::vector<std::vector<RangeSample>>& runs,
                                   const std::vector<std::string>& run_names,
                                   const std::vector<ReferenceProfile>& references, double guess_m, double search_m) {
    if (runs.size() != run_names.size()) throw std::invalid_argument("one name per run is needed");
    if (references.size() != 1 && references.size() != runs.size())
        throw std::invalid_argument("give one reference profile, or one per run");
    std::vector<double> speeds;
    for (std::size_t r = 0; r < runs.size(); ++r) {
        if (runs[r].empty()) throw std::invalid_argument(run_names[r] + ": the run has no samples of this sensor");
        double sum = 0.0;
        for (const RangeSample& s : runs[r]) sum += s.speed_mps;
        speeds.push_back(sum / static_cast<double>(runs[r].size()));
    }
    const auto [lo, hi] = std::minmax_element(speeds.begin(), speeds.end());
    if (speeds.empty() || !(*hi - *lo > kDistinctSpeeds * std::max(std::abs(*lo), std::abs(*hi))))
        throw std::invalid_argument("offset calibration needs runs at two or more distinct speeds (got " +
                                    std::to_string(speeds.size()) + " run(s), all at about the same speed): b1 and b2 "
                                    "cannot be separated");
    OffsetCalibration out;
    std::vector<double> shifts, sigmas, xcorr;
    for (std::size_t r = 0; r < runs.size(); ++r) {
        std::vector<double> x, z;
        for (const RangeSample& s : runs[r]) {
            x.push_back(s.s_m);
            z.push_back(s.z_m);
        }
        const ReferenceProfile& ref = references.size() == 1 ? references[0] : references[r];
        RunShift shift;
        try {
            shift = register_run(x, z, ref.x_m, ref.z_m, guess_m, search_m, ref.leaning_datum);
        } catch (const std::invalid_argument& e) {
            throw std::invalid_argument(run_names[r] + ": " + e.what());
        }
        if (!std::isfinite(shift.shift_sigma_m))
            throw std::invalid_argument(run_names[r] + ": the reference profile is flat where the run's samples lie: "
                                        "no slope to register on, the run's shift cannot be determined (give a "
                                        "reference with relief: bumps, ramps)");
        shift.source = run_names[r];
        shift.speed_mps = speeds[r];
        out.runs.push_back(shift);
        shifts.push_back(shift.shift_m);
        sigmas.push_back(shift.shift_sigma_m);
        xcorr.push_back(shift.xcorr_shift_m);
    }
    fit_offset_line(speeds, shifts, sigmas, out.b1_s, out.b2_m, &out.b1_sigma_s, &out.b2_sigma_m);
    fit_offset_line(speeds, xcorr, std::vector<double>(speeds.size(), 0.0), out.b1_xcorr_s, out.b2_xcorr_m, nullptr,
                    nullptr);
    return out;
}

double geometric_foot_m(const RangeSensor& s) { return s.x_m + s.height_m * std::tan(s.pitch_deg * M_PI / 180.0); }

RangeCalibration calibrate_offsets(const std::vector<RangeSensor>& layout, RangeCalibration cal,
                                   const std::vector<std::string>& run_paths, const std::vector<RangeMotion>& motions,
                                   const std::vector<std::vector<ReferenceProfile>>& references, double search_m) {
    check_search(search_m);
    if (references.size() != 1 && references.size() != layout.size())
        throw std::runtime_error("give one set of reference profiles, or one per sensor");
    if (run_paths.size() != motions.size())
        throw std::runtime_error("give one motion per run (" + std::to_string(run_paths.size()) + " runs, " +
                                 std::to_string(motions.size()) + " motions)");
    RangeCalibration raw = cal;  // samples where the axle was: b1 = b2 = 0
    for (const RangeSensor& s : layout) raw.sensors[s.id].offset = OffsetCalibration{};
    std::vector<std::vector<RangeSample>> all;
    for (std::size_t r = 0; r < run_paths.size(); ++r) all.push_back(read_range_samples(run_paths[r], layout, raw,
        motions[r]));
    for (std::size_t k = 0; k < layout.size(); ++k) {
        std::vector<std::vector<RangeSample>> runs(run_paths.size());
        for (std::size_t r = 0; r < all.size(); ++r)
            for (const RangeSample& x : all[r])
                if (x.sensor == static_cast<std::int32_t>(k)) runs[r].push_back(x);
        try {
            cal.sensors[layout[k].id].offset =
                calibrate_offset(runs, run_paths, references[references.size() == 1 ? 0 : k],
                    geometric_foot_m(layout[k]), search_m);
        } catch (const std::invalid_argument& e) {
            throw std::runtime_error("sensor '" + layout[k].id + "': " + e.what());
        }
    }
    return cal;
}

}  // namespace roadpreview
