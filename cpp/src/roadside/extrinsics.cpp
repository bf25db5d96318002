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

// The static scene of one scanner: per-beam medians (BackgroundModel) as points in the site frame, z = 0.
Cloud::Ptr static_cloud(const std::vector<LaserScan>& scans, const Pose2& pose, const char* which) {
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
    for (const auto& p : pts) cloud->push_back({static_cast<float>(p.x_m), static_cast<float>(p.y_m), 0.0f});
    return cloud;
}

}  // namespace

ExtrinsicsResult register_scanners(const std::vector<LaserScan>& fixed, const Pose2& fixed_pose,
                                   const std::vector<LaserScan>& moving, const Pose2& moving_pose,
                                   double max_distance_m) {
    // Points relative to a local origin near the scene keep float precision for site coordinates far from 0.
    const auto target = static_cloud(fixed, fixed_pose, "fixed");
    const auto source = static_cloud(moving, moving_pose, "moving");
    pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
    icp.setTransformationEstimation(
        pcl::make_shared<pcl::registration::TransformationEstimation2D<pcl::PointXYZ, pcl::PointXYZ>>());
    icp.setInputSource(source);
    icp.setInputTarget(target);
    icp.setMaxCorrespondenceDistance(max_distance_m);
    icp.setMaximumIterations(100);
    icp.setTransformationEpsilon(1e-10);
    icp.setEuclideanFitnessEpsilon(1e-10);
    Cloud aligned;
    icp.align(aligned);
    const Eigen::Matrix4f t = icp.getFinalTransformation();
    const double yaw = std::atan2(t(1, 0), t(0, 0));
    ExtrinsicsResult r;
    r.converged = icp.hasConverged();
    r.fitness_m2 = icp.getFitnessScore(max_distance_m);
    r.matched_points = static_cast<int>(source->size());
    // New pose = T ∘ old pose.
    r.pose.x_m = t(0, 0) * moving_pose.x_m + t(0, 1) * moving_pose.y_m + t(0, 3);
    r.pose.y_m = t(1, 0) * moving_pose.x_m + t(1, 1) * moving_pose.y_m + t(1, 3);
    r.pose.yaw_rad = moving_pose.yaw_rad + yaw;
    return r;
}

}  // namespace roadpreview::roadside
