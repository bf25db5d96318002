// SPDX-License-Identifier: BSD-3-Clause
#include "obstacles/grid_radius_search.hpp"

#include <stdexcept>

#include <boost/pending/disjoint_sets.hpp>

namespace roadpreview {

GridRadiusSearch::GridRadiusSearch(double column_edge) : Search("GridRadiusSearch", false), column_edge_(column_edge) {
    if (!(column_edge > 0.0)) throw std::invalid_argument("GridRadiusSearch: the column edge must be positive");
}

void GridRadiusSearch::setInputCloud(const PointCloudConstPtr& cloud, const IndicesConstPtr& indices) {
    input_ = cloud;
    indices_ = indices;
    grid_.rebuild(column_edge_, [&](std::vector<ColumnGrid::Point>& points) {
        const auto add = [&](pcl::index_t i) {
            const pcl::PointXYZ& p = (*cloud)[static_cast<std::size_t>(i)];
            points.push_back({p.x, p.y, p.z, i});
        };
        if (indices) {
            for (const auto i : *indices) add(i);
        } else {
            for (std::size_t i = 0; i < cloud->size(); ++i) add(static_cast<pcl::index_t>(i));
        }
    });
}

namespace {

// The square of the distance, in float and summed in FLANN's order as pcl::KdTreeFLANN computes it.
template <class P>
float sqr_distance(const P& p, const ColumnGrid::Point& q) {
    const float dx = p.x - q.x, dy = p.y - q.y, dz = p.z - q.z;
    float d = dx * dx;
    d += dy * dy;
    d += dz * dz;
    return d;
}

// The columns visited reach a little beyond the radius: float rounding can accept a point just outside it.
double reach(double radius) { return radius * (1.0 + 1e-5); }

}  // namespace

int GridRadiusSearch::radiusSearch(const pcl::PointXYZ& point, double radius, pcl::Indices& k_indices,
                                   std::vector<float>& k_sqr_distances, unsigned int max_nn) const {
    k_indices.clear();
    k_sqr_distances.clear();
    const auto sqr_radius = static_cast<float>(radius * radius);  // as pcl::KdTreeFLANN
    const double r = reach(radius);
    grid_.visit_columns(point.x - r, point.x + r, point.y - r, point.y + r, [&](const ColumnGrid::Point& q) {
        const float d = sqr_distance(point, q);
        if (d >= sqr_radius) return;
        k_indices.push_back(q.index);
        k_sqr_distances.push_back(d);
    });
    if (sorted_results_ || (max_nn > 0 && k_indices.size() > max_nn)) sortResults(k_indices, k_sqr_distances);
    if (max_nn > 0 && k_indices.size() > max_nn) {
        k_indices.resize(max_nn);
        k_sqr_distances.resize(max_nn);
    }
    return static_cast<int>(k_indices.size());
}

// Every pair the searches would join, found once: for each point, the points after it in the grid's order that a
// radius search about it would return (a pair closer than the radius lies within the reach of both). A pair whose
// points are joined already needs no distance.
std::int32_t euclidean_components(const GridRadiusSearch& search, double tolerance, ComponentScratch& scratch,
                                  std::vector<std::int32_t>& component_of) {
    if (search.getIndices()) throw std::invalid_argument("euclidean_components: the search must grid its whole cloud");
    const auto n = search.getInputCloud()->size();
    scratch.parent.resize(n);
    scratch.rank.resize(n);
    boost::disjoint_sets<int*, std::int32_t*> sets(scratch.rank.data(), scratch.parent.data());
    for (std::size_t i = 0; i < n; ++i) sets.make_set(static_cast<std::int32_t>(i));
    const auto sqr_radius = static_cast<float>(tolerance * tolerance);
    search.grid().visit_pairs(reach(tolerance), [&](const ColumnGrid::Point& p, const ColumnGrid::Point& q) {
        const std::int32_t a = sets.find_set(p.index), b = sets.find_set(q.index);
        if (a != b && sqr_distance(p, q) < sqr_radius) sets.link(a, b);
    });
    // Numbered in the order of their first points, as growing them from each point not yet taken numbers them.
    component_of.assign(n, -1);
    scratch.number.assign(n, -1);
    std::int32_t components = 0;
    for (std::size_t i = 0; i < n; ++i) {
        std::int32_t& number = scratch.number[static_cast<std::size_t>(sets.find_set(static_cast<std::int32_t>(i)))];
        if (number < 0) number = components++;
        component_of[i] = number;
    }
    return components;
}

int GridRadiusSearch::nearestKSearch(const pcl::PointXYZ&, int, pcl::Indices&, std::vector<float>&) const {
    throw std::logic_error("GridRadiusSearch answers radius searches only");
}

}  // namespace roadpreview
