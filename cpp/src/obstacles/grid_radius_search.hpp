// SPDX-License-Identifier: BSD-3-Clause
// Internal: a pcl::search::Search answering radius searches from a grid of columns, for PCL's Euclidean
// cluster extraction. With the query radius fixed and close to the column edge, a query visits the 3 × 3
// columns around its point (every height: sorting each column by height and visiting only the radius's range of
// it was 12 % slower on the KITTI frames' voxel centroids), where a k-d tree (PCL's KdTree, FlannSearch, FLANN
// called directly) or PCL's octree walks many nodes and leaves: bench/obstacles.py measured them 2–6 times slower
// on the obstacle stage's voxel centroids. The neighbours are those PCL's KdTree returns, the same float test.
#pragma once

#include <vector>

#include <pcl/point_types.h>
#include <pcl/search/search.h>

#include "core/column_grid.hpp"

namespace roadpreview {

class GridRadiusSearch : public pcl::search::Search<pcl::PointXYZ> {
public:
    /// `column_edge` (m, > 0): the grid's column edge, best about the radius that will be searched.
    explicit GridRadiusSearch(double column_edge);

    /// Grids the cloud's points picked by `indices` (all when null); results are cloud indices.
    void setInputCloud(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices = IndicesConstPtr()) override;

    /// The points whose squared distance, in float as FLANN computes it, is less than radius² (as PCL's
    /// KdTree); unordered unless sorted results were asked for; with max_nn > 0 the max_nn nearest of them.
    int radiusSearch(const pcl::PointXYZ& point, double radius, pcl::Indices& k_indices,
                     std::vector<float>& k_sqr_distances, unsigned int max_nn = 0) const override;

    /// Not supported: throws std::logic_error (Euclidean clustering needs radius searches only).
    int nearestKSearch(const pcl::PointXYZ& point, int k, pcl::Indices& k_indices,
                       std::vector<float>& k_sqr_distances) const override;

    /// The grid of the input cloud's points.
    const ColumnGrid& grid() const { return grid_; }

private:
    double column_edge_;
    ColumnGrid grid_;
};

/// Buffers of euclidean_components, kept between calls so that clustering a stream of frames allocates nothing.
struct ComponentScratch {
    std::vector<std::int32_t> parent, number;  // of each point: its disjoint set's parent, its set's number
    std::vector<int> rank;
};

/// The clusters of PCL's Euclidean cluster extraction (pcl::extractEuclideanClusters, every size kept): the
/// connected components of the search's whole input cloud (it must have no indices), points joined when closer
/// than `tolerance` by the float test of radiusSearch. Where PCL grows each cluster by a radius search about every
/// point of it (meeting each pair twice, and allocating a queue and an index list per cluster), each pair the
/// searches would meet is tested once, and not at all when its points are joined already (Boost's disjoint sets),
/// into buffers kept between frames. Writes each point's component, numbered in the order of their first points
/// (PCL's extract() then lists its clusters largest first), and returns how many there are.
std::int32_t euclidean_components(const GridRadiusSearch& search, double tolerance, ComponentScratch& scratch,
                                  std::vector<std::int32_t>& component_of);

}  // namespace roadpreview
