// The obstacle stage's radius search (an internal piece) against PCL's KdTree, which it replaces: the same
// neighbours for every query, hence the same Euclidean clusters.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

#include <pcl/search/kdtree.h>
#include <pcl/segmentation/extract_clusters.h>

#include "core/column_grid.hpp"
#include "obstacles/grid_radius_search.hpp"

namespace rp = roadpreview;

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

// Points uniform in [0, extent)² × [0, height): with the spacing near the radius, many neighbours sit close
// to it; `extent` far above the column edge makes the grid widen its columns.
Cloud::Ptr random_cloud(int n, double extent, double height, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> xy(0.0f, static_cast<float>(extent)), z(0.0f, static_cast<float>(height));
    auto cloud = pcl::make_shared<Cloud>();
    for (int i = 0; i < n; ++i) cloud->push_back(pcl::PointXYZ(xy(rng), xy(rng), z(rng)));
    return cloud;
}

// A 0.25 m lattice: neighbours exactly one or two radii away, which a strict "less than" must exclude.
Cloud::Ptr lattice() {
    auto cloud = pcl::make_shared<Cloud>();
    for (int i = 0; i < 12; ++i)
        for (int j = 0; j < 12; ++j)
            for (int k = 0; k < 4; ++k) cloud->push_back(pcl::PointXYZ(0.25f * i, 0.25f * j, 0.25f * k));
    return cloud;
}

using Neighbours = std::vector<std::pair<pcl::index_t, float>>;

Neighbours search(const pcl::search::Search<pcl::PointXYZ>& s, const pcl::PointXYZ& p, double radius,
                  unsigned max_nn = 0) {
    pcl::Indices indices;
    std::vector<float> sqr_distances;
    s.radiusSearch(p, radius, indices, sqr_distances, max_nn);
    Neighbours found;
    for (std::size_t k = 0; k < indices.size(); ++k) found.emplace_back(indices[k], sqr_distances[k]);
    std::sort(found.begin(), found.end());
    return found;
}

void expect_same_neighbours(const Cloud::Ptr& cloud, const pcl::IndicesPtr& indices, double radius) {
    pcl::search::KdTree<pcl::PointXYZ> tree;
    rp::GridRadiusSearch grid(radius);
    tree.setInputCloud(cloud, indices);
    grid.setInputCloud(cloud, indices);
    std::size_t total = 0;
    for (const auto& p : *cloud) {
        const Neighbours want = search(tree, p, radius);
        ASSERT_EQ(search(grid, p, radius), want) << "query (" << p.x << ", " << p.y << ", " << p.z << ")";
        total += want.size();
    }
    EXPECT_GT(total, cloud->size());  // the queries found neighbours besides themselves
}

std::vector<pcl::Indices> clusters(const Cloud::Ptr& cloud, pcl::search::Search<pcl::PointXYZ>::Ptr search,
                                   double tolerance) {
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
    extraction.setSearchMethod(std::move(search));
    extraction.setClusterTolerance(tolerance);
    extraction.setInputCloud(cloud);
    std::vector<pcl::PointIndices> found;
    extraction.extract(found);
    std::vector<pcl::Indices> out;
    for (auto& c : found) out.push_back(std::move(c.indices));  // each ascending
    std::sort(out.begin(), out.end());
    return out;
}

}  // namespace

TEST(GridRadiusSearch, FindsWhatPclsKdTreeFinds) {
    expect_same_neighbours(random_cloud(4000, 12.0, 3.0, 1), nullptr, 0.5);
    expect_same_neighbours(lattice(), nullptr, 0.5);               // two steps: excluded
    expect_same_neighbours(lattice(), nullptr, std::sqrt(0.125));  // the diagonal of a step: excluded
}

TEST(GridRadiusSearch, WidenedColumnsOfAFarSpreadCloudStillFindEveryNeighbour) {
    auto cloud = random_cloud(3000, 2000.0, 3.0, 2);
    const auto patch = random_cloud(1000, 20.0, 3.0, 3);  // a dense patch in one corner
    for (const auto& p : *patch) cloud->push_back(p);
    expect_same_neighbours(cloud, nullptr, 0.5);
}

TEST(GridRadiusSearch, SearchesOnlyTheIndexedPointsAndReturnsCloudIndices) {
    const auto cloud = random_cloud(3000, 10.0, 2.0, 4);
    auto odd = pcl::make_shared<pcl::Indices>();
    for (pcl::index_t i = 1; i < static_cast<pcl::index_t>(cloud->size()); i += 2) odd->push_back(i);
    expect_same_neighbours(cloud, odd, 0.6);
}

TEST(GridRadiusSearch, MaxNnKeepsTheNearestAndSortedResultsAreSorted) {
    const auto cloud = random_cloud(3000, 8.0, 2.0, 5);
    pcl::search::KdTree<pcl::PointXYZ> tree;
    rp::GridRadiusSearch grid(0.5);
    tree.setInputCloud(cloud);
    grid.setInputCloud(cloud);
    for (std::size_t i = 0; i < cloud->size(); i += 97) EXPECT_EQ(search(grid, (*cloud)[i], 0.8, 5), search(tree, (*cloud)[i], 0.8, 5));
    grid.setSortedResults(true);
    pcl::Indices indices;
    std::vector<float> sqr_distances;
    grid.radiusSearch((*cloud)[0], 1.0, indices, sqr_distances);
    ASSERT_GT(indices.size(), 3u);
    EXPECT_TRUE(std::is_sorted(sqr_distances.begin(), sqr_distances.end()));
    EXPECT_EQ(indices.front(), 0);
}

TEST(GridRadiusSearch, GivesPclsEuclideanClusterExtractionTheKdTreesClusters) {
    const auto cloud = random_cloud(6000, 30.0, 2.0, 6);  // sparse: many clusters of a few points
    const auto want = clusters(cloud, pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>(), 0.5);
    EXPECT_GT(want.size(), 50u);
    EXPECT_EQ(clusters(cloud, pcl::make_shared<rp::GridRadiusSearch>(0.5), 0.5), want);
}

// The clusters the obstacle stage grows itself (into kept buffers) are those of PCL's extraction (which lists
// them largest first; the components are numbered by their first point), also when the same scratch serves
// another cloud, when the grid is rebuilt in place, on a lattice whose neighbours lie exactly one tolerance apart (a
// strict "less than" keeps every point apart) and on a far-spread cloud whose grid widens its columns.
TEST(GridRadiusSearch, EuclideanComponentsAreThoseOfPclsExtraction) {
    rp::ComponentScratch scratch;
    rp::GridRadiusSearch grid(0.5);
    auto spread = random_cloud(3000, 2000.0, 3.0, 2);
    const auto patch = random_cloud(1000, 20.0, 3.0, 3);  // a dense patch in one corner
    for (const auto& p : *patch) spread->push_back(p);
    const std::tuple<Cloud::Ptr, double, std::int32_t> cases[] = {{random_cloud(6000, 30.0, 2.0, 6), 0.5, 50},
                                                                  {random_cloud(6000, 30.0, 2.0, 8), 0.5, 50},
                                                                  {lattice(), 0.25, 575},
                                                                  {spread, 0.5, 3000}};
    for (const auto& [cloud, tolerance, at_least] : cases) {
        pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
        extraction.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
        extraction.setClusterTolerance(tolerance);
        extraction.setInputCloud(cloud);
        std::vector<pcl::PointIndices> want;
        extraction.extract(want);
        grid.setInputCloud(cloud);
        std::vector<std::int32_t> component_of;
        const auto n = rp::euclidean_components(grid, tolerance, scratch, component_of);
        ASSERT_EQ(static_cast<std::size_t>(n), want.size());
        EXPECT_GT(n, at_least);
        std::vector<std::int32_t> seen;  // each cluster's component: one per cluster, all different
        std::vector<std::int32_t> first_of(want.size());
        for (const auto& cluster : want) {
            const std::int32_t c = component_of[static_cast<std::size_t>(cluster.indices.front())];
            for (const auto i : cluster.indices) ASSERT_EQ(component_of[static_cast<std::size_t>(i)], c);
            seen.push_back(c);
            first_of[static_cast<std::size_t>(c)] = *std::min_element(cluster.indices.begin(), cluster.indices.end());
        }
        std::sort(seen.begin(), seen.end());
        EXPECT_EQ(std::unique(seen.begin(), seen.end()), seen.end());
        EXPECT_TRUE(std::is_sorted(first_of.begin(), first_of.end()));  // numbered by their first points
    }
    auto odd = pcl::make_shared<pcl::Indices>(pcl::Indices{1, 3});
    grid.setInputCloud(lattice(), odd);
    std::vector<std::int32_t> component_of;
    EXPECT_THROW(rp::euclidean_components(grid, 0.5, scratch, component_of), std::invalid_argument);
}

TEST(GridRadiusSearch, RejectsWhatItCannotDo) {
    EXPECT_THROW(rp::GridRadiusSearch(0.0), std::invalid_argument);
    rp::GridRadiusSearch grid(0.5);
    grid.setInputCloud(lattice());
    pcl::Indices indices;
    std::vector<float> sqr_distances;
    EXPECT_THROW(grid.nearestKSearch(pcl::PointXYZ(0, 0, 0), 3, indices, sqr_distances), std::logic_error);
    grid.setInputCloud(pcl::make_shared<Cloud>());  // an empty cloud finds nothing
    EXPECT_EQ(grid.radiusSearch(pcl::PointXYZ(0, 0, 0), 1.0, indices, sqr_distances), 0);
}

TEST(ColumnGrid, VisitsEveryPointInARectangleOnce) {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-50.0f, 50.0f);
    std::vector<rp::ColumnGrid::Point> points;
    for (std::int32_t i = 0; i < 5000; ++i) points.push_back({u(rng), u(rng), u(rng), i});
    const rp::ColumnGrid grid(points, 1.0);
    for (int q = 0; q < 200; ++q) {
        const double x0 = u(rng), y0 = u(rng), x1 = x0 + 0.1 * q, y1 = y0 + 0.05 * q;
        std::vector<std::int32_t> seen, want;
        grid.visit_columns(x0, x1, y0, y1, [&](const rp::ColumnGrid::Point& p) {
            if (p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1) seen.push_back(p.index);
        });
        for (const auto& p : points)
            if (p.x >= x0 && p.x <= x1 && p.y >= y0 && p.y <= y1) want.push_back(p.index);
        std::sort(seen.begin(), seen.end());
        EXPECT_EQ(seen, want);
    }
}

TEST(ColumnGrid, VisitsEveryPairWithinReachOnce) {
    std::mt19937 rng(9);
    std::uniform_real_distribution<float> u(-20.0f, 20.0f);
    std::vector<rp::ColumnGrid::Point> points;
    for (std::int32_t i = 0; i < 3000; ++i) points.push_back({u(rng), u(rng), 0.0f, i});
    for (const double edge : {0.7, 0.5}) {  // columns wider than the reach, and exactly as wide
        const rp::ColumnGrid grid(points, edge);
        const double reach = 0.5;
        const auto near = [&](const rp::ColumnGrid::Point& p, const rp::ColumnGrid::Point& q) {
            return std::abs(double(p.x) - q.x) <= reach && std::abs(double(p.y) - q.y) <= reach;
        };
        std::vector<std::pair<std::int32_t, std::int32_t>> seen, want;
        grid.visit_pairs(reach, [&](const rp::ColumnGrid::Point& p, const rp::ColumnGrid::Point& q) {
            if (near(p, q)) seen.emplace_back(std::min(p.index, q.index), std::max(p.index, q.index));
        });
        for (std::size_t a = 0; a < points.size(); ++a)
            for (std::size_t b = a + 1; b < points.size(); ++b)
                if (near(points[a], points[b])) want.emplace_back(points[a].index, points[b].index);
        std::sort(seen.begin(), seen.end());
        EXPECT_GT(want.size(), 1000u);
        EXPECT_EQ(seen, want);  // each once: a pair seen twice would appear twice
    }
}
