// SPDX-License-Identifier: BSD-3-Clause
#include "obstacles/grid_radius_search.hpp"

#include <stdexcept>

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

int GridRadiusSearch::radiusSearch(const pcl::PointXYZ& point, double radius, pcl::Indices& k_indices,
                                   std::vector<float>& k_sqr_distances, unsigned int max_nn) const {
    k_indices.clear();
    k_sqr_distances.clear();
    const auto sqr_radius = static_cast<float>(radius * radius);  // as pcl::KdTreeFLANN
    // The columns visited reach a little beyond the radius: float rounding can accept a point just outside it.
    const double reach = radius * (1.0 + 1e-5);
    grid_.visit_columns(point.x - reach, point.x + reach, point.y - reach, point.y + reach,
                        [&](const ColumnGrid::Point& q) {
                            const float dx = point.x - q.x, dy = point.y - q.y, dz = point.z - q.z;
                            float sqr_distance = dx * dx;  // summed in FLANN's order
                            sqr_distance += dy * dy;
                            sqr_distance += dz * dz;
                            if (sqr_distance >= sqr_radius) return;
                            k_indices.push_back(q.index);
                            k_sqr_distances.push_back(sqr_distance);
                        });
    if (sorted_results_ || (max_nn > 0 && k_indices.size() > max_nn)) sortResults(k_indices, k_sqr_distances);
    if (max_nn > 0 && k_indices.size() > max_nn) {
        k_indices.resize(max_nn);
        k_sqr_distances.resize(max_nn);
    }
    return static_cast<int>(k_indices.size());
}

std::int32_t euclidean_components(const GridRadiusSearch& search, double tolerance, ComponentScratch& scratch,
                                  std::vector<std::int32_t>& component_of) {
    const auto& cloud = *search.getInputCloud();
    component_of.assign(cloud.size(), -1);
    std::int32_t components = 0;
    for (std::size_t seed = 0; seed < cloud.size(); ++seed) {
        if (component_of[seed] >= 0) continue;
        scratch.queue.assign(1, static_cast<std::int32_t>(seed));
        component_of[seed] = components;
        for (std::size_t next = 0; next < scratch.queue.size(); ++next) {
            const auto& p = cloud[static_cast<std::size_t>(scratch.queue[next])];
            search.radiusSearch(p, tolerance, scratch.neighbours, scratch.sqr_distances);
            for (const auto j : scratch.neighbours) {
                if (component_of[static_cast<std::size_t>(j)] >= 0) continue;
                component_of[static_cast<std::size_t>(j)] = components;
                scratch.queue.push_back(j);
            }
        }
        ++components;
    }
    return components;
}

int GridRadiusSearch::nearestKSearch(const pcl::PointXYZ&, int, pcl::Indices&, std::vector<float>&) const {
    throw std::logic_error("GridRadiusSearch answers radius searches only");
}

}  // namespace roadpreview
