// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/ground/ground.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>

#include "ground/ground_pcl.hpp"
#include "ground/plane_fit.hpp"
#include "ground/zone_scratch.hpp"
#include "roadpreview/ground/zones.hpp"

namespace roadpreview {

std::optional<PlaneFit> plane_fit(const Moments& m) {
    if (m.count < 3) return std::nullopt;
    const double n = static_cast<double>(m.count);
    const Eigen::Vector3d mean_q = m.sum / n;
    const Eigen::Matrix3d outer = m.outer.selfadjointView<Eigen::Lower>();
    const Eigen::Matrix3d cov = outer / n - mean_q * mean_q.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    // Collinear or coincident points span no plane.
    if (eig.info() != Eigen::Success || !(eig.eigenvalues()(1) > 1e-12 * eig.eigenvalues()(2)))
        return std::nullopt;
    Eigen::Vector3d normal = eig.eigenvectors().col(0).normalized();  // eigenvalues ascend
    if (normal.z() < 0.0) normal = -normal;
    const Eigen::Vector3d centre = m.shift + mean_q;
    return PlaneFit{{normal.x(), normal.y(), normal.z(), -normal.dot(centre)}, centre,
                    std::max(0.0, eig.eigenvalues()(0)), eig.eigenvalues()(1)};
}

double tilt_deg(const Plane& plane) { return std::acos(std::clamp(plane[2], -1.0, 1.0)) * 180.0 / M_PI; }

namespace {

std::optional<Plane> plane_from(const Moments& m) {
    const auto fit = plane_fit(m);
    return fit ? std::optional<Plane>(fit->plane) : std::nullopt;
}

Eigen::Vector3d row(PointsView pts, Eigen::Index i) { return pts.row(i).cast<double>().transpose(); }

// The paper's method: fit, drop points more than `threshold` above the plane, repeat. Points more than
// `max_depth_m` below the last plane are then not ground either: they took part in the fits, as in the paper (the
// first plane, fitted to every point, may lie metres above the road), but no wheel rolls on them.
void pca_ground(PointsView pts, const GroundConfig& cfg, GroundFit& fit) {
    fit.status = GroundStatus::Found;
    fit.plane.reset();
    fit.mask.assign(static_cast<std::size_t>(pts.rows()), 1);
    Moments kept;
    for (Eigen::Index i = 0; i < pts.rows(); ++i) kept.add(row(pts, i));
    for (int k = 0; k < cfg.pca_iterations; ++k) {
        fit.plane = plane_from(kept);
        if (!fit.plane) break;
        // The kept set only shrinks: its moments lose the points dropped (a few after the first fit).
        for (Eigen::Index i = 0; i < pts.rows(); ++i) {
            if (!fit.mask[i]) continue;
            const Eigen::Vector3d p = row(pts, i);
            if (height_above(*fit.plane, p.x(), p.y(), p.z()) > cfg.pca_threshold_m) {
                fit.mask[i] = 0;
                kept.remove(p);
            }
        }
    }
    if (!fit.plane) {
        fit.count = 0;
        std::fill(fit.mask.begin(), fit.mask.end(), 0);
        return;
    }
    fit.count = kept.count;
    for (Eigen::Index i = 0; i < pts.rows(); ++i) {
        if (fit.mask[i] && height_above(*fit.plane, pts(i, 0), pts(i, 1), pts(i, 2)) < -cfg.max_depth_m) {
            fit.mask[i] = 0;
            --fit.count;
        }
    }
}

// PCL's up-axis-constrained plane model; subclassed only to set the seed of its sampler.
class SeededPlaneModel : public pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ> {
public:
    SeededPlaneModel(const pcl::PointCloud<pcl::PointXYZ>::ConstPtr& cloud, const pcl::Indices& indices,
                     std::uint32_t seed)
        : pcl::SampleConsensusModelPerpendicularPlane<pcl::PointXYZ>(cloud, indices) {
        rng_alg_.seed(seed);
    }
};

// PCL finds the consensus set; the plane is then refined by this file's double-precision PCA on it, and
// the ground is every point within the distance of the refined plane (method.md §1). The sampler draws
// from the points in the order of their input rows, as if the ROI had not been ordered by cell.
GroundFit ransac_ground(const RoiCloud& roi, const GroundConfig& cfg) {
    const auto& cloud = roi.cloud;
    const PointsView pts = roi.view();
    GroundFit fit;
    fit.mask.assign(cloud->size(), 0);
    // Points that span no plane (collinear, coincident) hold no ground, and PCL's sampler would print a complaint to
    // stderr for each of its draws: up to ransac_max_iterations lines a frame.
    const auto any_plane = fit_plane(pts);
    if (cloud->size() < 3 || !any_plane) return fit;
    const pcl::Indices in_input_order(roi.input_order.begin(), roi.input_order.end());
    auto model = std::make_shared<SeededPlaneModel>(cloud, in_input_order, cfg.ransac_seed);
    model->setAxis(Eigen::Vector3f::UnitZ());
    model->setEpsAngle(cfg.max_tilt_deg * M_PI / 180.0);
    pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, cfg.ransac_distance_m);
    ransac.setMaxIterations(cfg.ransac_max_iterations);
    ransac.setProbability(0.99);
    if (!ransac.computeModel()) {  // no sample within the tilt limit: say so when the points' plane is tilted
        if (!within_tilt(*any_plane, cfg.max_tilt_deg)) fit.status = GroundStatus::TiltedGround;
        return fit;
    }

    pcl::Indices inliers;
    ransac.getInliers(inliers);
    for (const auto i : inliers) fit.mask[static_cast<std::size_t>(i)] = 1;
    fit.plane = fit_plane(pts, &fit.mask);
    if (!fit.plane) {
        std::fill(fit.mask.begin(), fit.mask.end(), 0);
        return fit;
    }
    fit.count = 0;
    for (Eigen::Index i = 0; i < pts.rows(); ++i) {
        const bool near = std::abs(height_above(*fit.plane, pts(i, 0), pts(i, 1), pts(i, 2))) <= cfg.ransac_distance_m;
        fit.mask[static_cast<std::size_t>(i)] = near;
        fit.count += near;
    }
    return fit;
}

}  // namespace

std::optional<Plane> fit_plane(PointsView points, const std::vector<std::uint8_t>* mask) {
    Moments m;
    for (Eigen::Index i = 0; i < points.rows(); ++i)
        if (!mask || (*mask)[static_cast<std::size_t>(i)]) m.add(row(points, i));
    return plane_from(m);
}

GroundScratch::GroundScratch() = default;
GroundScratch::~GroundScratch() = default;

void fit_ground(const RoiCloud& roi, const GroundConfig& cfg, GroundScratch& scratch, GroundFit& fit, int threads) {
    if (cfg.method == GroundMethod::Zones) {
        if (!scratch.zones) scratch.zones = std::make_unique<ZoneScratch>(cfg);
        zone_ground(roi.view(), cfg, *scratch.zones, fit, threads);
    } else if (cfg.method == GroundMethod::Pca) {
        pca_ground(roi.view(), cfg, fit);
    } else {
        fit = ransac_ground(roi, cfg);
    }
    // A wall, a bank of vegetation: not ground. The zones hold each patch to the limit (their frame plane only
    // sums up upright patches, on a hillside it may lie steeper).
    if (cfg.method != GroundMethod::Zones && fit.plane && !within_tilt(*fit.plane, cfg.max_tilt_deg)) {
        std::fill(fit.mask.begin(), fit.mask.end(), 0);
        fit.plane.reset();
        fit.count = 0;
        fit.status = GroundStatus::TiltedGround;
    }
    if (!fit.plane && fit.status == GroundStatus::Found) fit.status = GroundStatus::NoGround;
}

GroundFit fit_ground(const RoiCloud& roi, const GroundConfig& cfg) {
    GroundScratch scratch;
    GroundFit fit;
    fit_ground(roi, cfg, scratch, fit);
    return fit;
}

GroundFit fit_ground(PointsView points, const GroundConfig& cfg) {
    RoiCloud roi;
    crop_roi(points, to_rigid_transform(Extrinsics{}), cfg, roi);  // the points are in the base frame already
    GroundFit in_roi = fit_ground(roi, cfg);
    GroundFit fit;
    fit.plane = in_roi.plane;
    fit.count = in_roi.count;
    fit.status = in_roi.status;
    fit.mask.assign(static_cast<std::size_t>(points.rows()), 0);
    for (std::size_t i = 0; i < in_roi.mask.size(); ++i) fit.mask[static_cast<std::size_t>(roi.input_index[i])] = in_roi.mask[i];
    return fit;
}

}  // namespace roadpreview
