// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/ground/ground.hpp"

#include <cmath>

#include <Eigen/Eigenvalues>
#include <pcl/sample_consensus/ransac.h>
#include <pcl/sample_consensus/sac_model_perpendicular_plane.h>

#include "ground/ground_pcl.hpp"

namespace roadpreview {
namespace {

// First and second moments of a point set, accumulated about a shift point so that the one-pass
// covariance keeps its precision far from the origin.
struct Moments {
    Eigen::Vector3d shift = Eigen::Vector3d::Zero();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
    std::int64_t count = 0;

    void add(const Eigen::Vector3d& p) {
        if (count == 0) shift = p;
        const Eigen::Vector3d q = p - shift;
        sum += q;
        outer.noalias() += q * q.transpose();
        ++count;
    }
};

std::optional<Plane> plane_from(const Moments& m) {
    if (m.count < 3) return std::nullopt;
    const double n = static_cast<double>(m.count);
    const Eigen::Vector3d mean_q = m.sum / n;
    const Eigen::Matrix3d cov = m.outer / n - mean_q * mean_q.transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    // Collinear or coincident points span no plane.
    if (eig.info() != Eigen::Success || !(eig.eigenvalues()(1) > 1e-12 * eig.eigenvalues()(2)))
        return std::nullopt;
    Eigen::Vector3d normal = eig.eigenvectors().col(0).normalized();  // eigenvalues ascend
    if (normal.z() < 0.0) normal = -normal;
    const Eigen::Vector3d centre = m.shift + mean_q;
    return Plane{normal.x(), normal.y(), normal.z(), -normal.dot(centre)};
}

Eigen::Vector3d row(PointsView pts, Eigen::Index i) { return pts.row(i).cast<double>().transpose(); }

// The paper's method: fit, drop points more than `threshold` above the plane, repeat.
GroundFit pca_ground(PointsView pts, const GroundConfig& cfg) {
    GroundFit fit;
    fit.mask.assign(static_cast<std::size_t>(pts.rows()), 1);
    Moments kept;
    for (Eigen::Index i = 0; i < pts.rows(); ++i) kept.add(row(pts, i));
    for (int k = 0; k < cfg.pca_iterations; ++k) {
        fit.plane = plane_from(kept);
        if (!fit.plane) break;
        kept = Moments{};
        for (Eigen::Index i = 0; i < pts.rows(); ++i) {
            if (!fit.mask[i]) continue;
            const Eigen::Vector3d p = row(pts, i);
            if (height_above(*fit.plane, p.x(), p.y(), p.z()) > cfg.pca_threshold_m) {
                fit.mask[i] = 0;
            } else {
                kept.add(p);
            }
        }
    }
    fit.count = fit.plane ? kept.count : 0;
    if (!fit.plane) std::fill(fit.mask.begin(), fit.mask.end(), 0);
    return fit;
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
    if (cloud->size() < 3) return fit;
    const pcl::Indices in_input_order(roi.input_order.begin(), roi.input_order.end());
    auto model = std::make_shared<SeededPlaneModel>(cloud, in_input_order, cfg.ransac_seed);
    model->setAxis(Eigen::Vector3f::UnitZ());
    model->setEpsAngle(cfg.ransac_max_tilt_deg * M_PI / 180.0);
    pcl::RandomSampleConsensus<pcl::PointXYZ> ransac(model, cfg.ransac_distance_m);
    ransac.setMaxIterations(cfg.ransac_max_iterations);
    ransac.setProbability(0.99);
    if (!ransac.computeModel()) return fit;

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

GroundFit fit_ground(const RoiCloud& roi, const GroundConfig& cfg) {
    if (cfg.method == GroundMethod::Pca) return pca_ground(roi.view(), cfg);
    return ransac_ground(roi, cfg);
}

GroundFit fit_ground(PointsView points, const GroundConfig& cfg) {
    RoiCloud roi;
    crop_roi(points, to_rigid_transform(Extrinsics{}), cfg, roi);  // the points are in the base frame already
    GroundFit in_roi = fit_ground(roi, cfg);
    GroundFit fit;
    fit.plane = in_roi.plane;
    fit.count = in_roi.count;
    fit.mask.assign(static_cast<std::size_t>(points.rows()), 0);
    for (std::size_t i = 0; i < in_roi.mask.size(); ++i) fit.mask[static_cast<std::size_t>(roi.input_index[i])] = in_roi.mask[i];
    return fit;
}

}  // namespace roadpreview
