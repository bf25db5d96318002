// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/roadside/extrinsics.hpp"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/transformation_estimation_2D.h>

#include <cmath>
#include <stdexcept>

#include "roadpreview/roadside/objects.hpp"

namespace roadpreview::roadside {
namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

// The static scene of one scanner: per-beam medians (BackgroundModel) as points in the site frame, z = 0. With
// `densify_m`, neighbouring beams closer than 0.5 m are joined by points every `densify_m`: a point-to-point ICP
// against that polyline behaves as point-to-line, so the two scanners' different beam samplings of one wall do
// not bias the result.
Cloud::Ptr static_cloud(const std::vector<LaserScan>& scans, const Pose2& pose, const char* which, double densify_m) {
    if (scans.empty()) throw std::invalid_argument(std::string("no scans of the ") + which + " scanner");
    BackgroundModel model;
    for (const auto& s : scans) model.learn(s);
    model.freeze();
    LaserScan median = scans.front();
    median.ranges_m = model.background_m();
    std::vector<Point2> pts;
    scan_points(median, pose, {}, pts);
    if (pts.size() < 20)
        throw std::invalid_argument(std::string("the ") + which + " scanner's static scene has " +
                                    std::to_string(pts.size()) + " points, at least 20 are needed");
    auto cloud = pcl::make_shared<Cloud>();
    for (std::size_t i = 0; i < pts.size(); ++i) {
        cloud->push_back({static_cast<float>(pts[i].x_m), static_cast<float>(pts[i].y_m), 0.0f});
        if (densify_m <= 0.0 || i + 1 == pts.size()) continue;
        const double dx = pts[i + 1].x_m - pts[i].x_m, dy = pts[i + 1].y_m - pts[i].y_m, gap = std::hypot(dx, dy);
        if (gap > 0.5) continue;  // a jump between surfaces, not one wall
        for (double f = densify_m / gap; f < 1.0; f += densify_m / gap)
            cloud->push_back({static_cast<float>(pts[i].x_m + f * dx), static_cast<float>(pts[i].y_m + f * dy), 0.0f});
    }
    return cloud;
}

}  // namespace

ExtrinsicsResult register_scanners(const std::vector<LaserScan>& fixed, const Pose2& fixed_pose,
                                   const std::vector<LaserScan>& moving, const Pose2& moving_pose,
                                   double max_distance_m) {
    const auto target = static_cloud(fixed, fixed_pose, "fixed", 0.02);
    const auto source = static_cloud(moving, moving_pose, "moving", 0.0);
    pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
    icp.setTransformationEstimation(
        pcl::make_shared<pcl::registration::TransformationEstimation2D<pcl::PointXYZ, pcl::PointXYZ>>());
    icp.setInputSource(source);
    icp.setInputTarget(target);
    icp.setMaximumIterations(100);
    icp.setTransformationEpsilon(1e-10);
    icp.setEuclideanFitnessEpsilon(1e-10);
    // Coarse to fine: the wide gate pulls the scans together, the narrow ones drop what only one scanner sees.
    Cloud aligned;
    Eigen::Matrix4f guess = Eigen::Matrix4f::Identity();
    for (const double gate_m : {max_distance_m, max_distance_m / 4.0, max_distance_m / 16.0}) {
        icp.setMaxCorrespondenceDistance(gate_m);
        icp.align(aligned, guess);
        guess = icp.getFinalTransformation();
    }
    const double fine_m = max_distance_m / 16.0;
    const Eigen::Matrix4f t = icp.getFinalTransformation();
    const double yaw = std::atan2(t(1, 0), t(0, 0));
    ExtrinsicsResult r;
    r.converged = icp.hasConverged();
    r.fitness_m2 = icp.getFitnessScore(fine_m);
    r.matched_points = static_cast<int>(source->size());
    // New pose = T ∘ old pose.
    r.pose.x_m = t(0, 0) * moving_pose.x_m + t(0, 1) * moving_pose.y_m + t(0, 3);
    r.pose.y_m = t(1, 0) * moving_pose.x_m + t(1, 1) * moving_pose.y_m + t(1, 3);
    r.pose.yaw_rad = moving_pose.yaw_rad + yaw;
    return r;
}

}  // namespace roadpreview::roadside
