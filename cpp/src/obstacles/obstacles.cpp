// SPDX-License-Identifier: BSD-3-Clause
#include "roadpreview/obstacles/obstacles.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <tuple>

#include "obstacles/grid_radius_search.hpp"
#include "core/median.hpp"
#include "obstacles/obstacles_pcl.hpp"
#include "roadpreview/profile/profile.hpp"

namespace roadpreview {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

// One cluster's points: a stretch of ObstacleScratch::members.
struct Members {
    const pcl::index_t *first, *last;
    const pcl::index_t* begin() const { return first; }
    const pcl::index_t* end() const { return last; }
    std::size_t size() const { return static_cast<std::size_t>(last - first); }
};

using Cloud = pcl::PointCloud<pcl::PointXYZ>;

// floor(v / edge), clamped so that an absurd (finite) coordinate cannot overflow the index; the integer
// conversion and its correction below zero spare a call of std::floor per coordinate.
std::int64_t voxel_index(float v, double edge) {
    const double q = std::clamp(static_cast<double>(v) / edge, -1e15, 1e15);
    const auto truncated = static_cast<std::int64_t>(q);
    return truncated - (q < static_cast<double>(truncated) ? 1 : 0);
}

// Stable counting sort of s.order by key(k) in [0, buckets).
template <class Key>
void counting_sort(ObstacleScratch& s, std::size_t buckets, Key key) {
    s.next.assign(buckets + 1, 0);
    for (const auto k : s.order) ++s.next[key(k) + 1];
    for (std::size_t b = 0; b < buckets; ++b) s.next[b + 1] += s.next[b];
    s.sorted.resize(s.order.size());
    for (const auto k : s.order) s.sorted[s.next[key(k)]++] = k;
    s.order.swap(s.sorted);
}

// s.order: positions 0 … n−1 of s.voxel ordered by voxel, each voxel's ascending: counting sorts by z, then by
// the (x, y) column when the spans are small (the ROI bounds x and y); one comparison sort otherwise.
void voxel_order(ObstacleScratch& s) {
    const auto& voxel = s.voxel;
    s.order.resize(voxel.size());
    for (std::size_t k = 0; k < s.order.size(); ++k) s.order[k] = static_cast<std::int32_t>(k);
    Voxel lo = voxel.front(), hi = voxel.front();
    for (const Voxel& v : voxel)
        for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], v[a]), hi[a] = std::max(hi[a], v[a]);
    const auto span = [&](int a) { return static_cast<std::uint64_t>(hi[a] - lo[a]) + 1; };
    const std::uint64_t most = 4 * voxel.size() + 4096;
    if (span(2) <= most && span(0) <= most && span(1) <= most / span(0)) {
        const auto offset = [&](std::int32_t k, int a) { return static_cast<std::size_t>(voxel[static_cast<std::size_t>(k)][a] - lo[a]); };
        counting_sort(s, span(2), [&](std::int32_t k) { return offset(k, 2); });
        counting_sort(s, span(0) * span(1), [&](std::int32_t k) { return offset(k, 0) * span(1) + offset(k, 1); });
    } else {
        std::sort(s.order.begin(), s.order.end(), [&](std::int32_t a, std::int32_t b) {
            return std::tie(voxel[static_cast<std::size_t>(a)], a) < std::tie(voxel[static_cast<std::size_t>(b)], b);
        });
    }
}

// The voxel centroids, each the mean of its candidates in ascending order (double precision).
void voxel_centroids(PointsView pts, const pcl::Indices& candidates, double edge, ObstacleScratch& s) {
    if (candidates.empty()) return;
    s.voxel.resize(candidates.size());
    for (std::size_t k = 0; k < candidates.size(); ++k)
        for (int a = 0; a < 3; ++a) s.voxel[k][a] = voxel_index(pts(candidates[k], a), edge);
    voxel_order(s);
    const auto& order = s.order;
    for (std::size_t first = 0, last = 0; first < order.size(); first = last) {
        const Voxel& v = s.voxel[static_cast<std::size_t>(order[first])];
        Vec3 sum{};
        for (last = first; last < order.size() && s.voxel[static_cast<std::size_t>(order[last])] == v; ++last) {
            const auto k = static_cast<std::size_t>(order[last]);
            for (int a = 0; a < 3; ++a) sum[a] += pts(candidates[k], a);
            s.representative_of[k] = static_cast<std::int32_t>(s.representatives->size());
        }
        const double n = static_cast<double>(last - first);
        s.representatives->push_back(pcl::PointXYZ(static_cast<float>(sum[0] / n), static_cast<float>(sum[1] / n),
                                                   static_cast<float>(sum[2] / n)));
    }
}

// Each distinct candidate, the first of its copies representing them all: identical points lie within any
// tolerance of each other, so the clusters are the same, and a degenerate cloud of 200,000 copies of one point no
// longer has the search meet 2·10¹⁰ pairs (40 s a frame).
void distinct_points(PointsView pts, const pcl::Indices& candidates, ObstacleScratch& s) {
    const auto at = [&](std::int32_t k) {
        const auto i = candidates[static_cast<std::size_t>(k)];
        return std::array<float, 3>{pts(i, 0), pts(i, 1), pts(i, 2)};
    };
    const std::size_t n = candidates.size();
    s.order.resize(n);
    for (std::size_t k = 0; k < n; ++k) s.order[k] = static_cast<std::int32_t>(k);
    std::sort(s.order.begin(), s.order.end(), [&](std::int32_t a, std::int32_t b) {
        return std::pair(at(a), a) < std::pair(at(b), b);
    });
    auto& first_copy = s.sorted;  // of each candidate: the first candidate at its place (the smallest index)
    first_copy.resize(n);
    for (std::size_t a = 0, b = 0; a < n; a = b)
        for (b = a; b < n && at(s.order[b]) == at(s.order[a]); ++b)
            first_copy[static_cast<std::size_t>(s.order[b])] = s.order[a];
    for (std::size_t k = 0; k < n; ++k) {
        const auto first = static_cast<std::size_t>(first_copy[k]);
        if (first < k) {
            s.representative_of[k] = s.representative_of[first];
            continue;
        }
        const auto i = candidates[k];
        s.representative_of[k] = static_cast<std::int32_t>(s.representatives->size());
        s.representatives->push_back(pcl::PointXYZ(pts(i, 0), pts(i, 1), pts(i, 2)));
    }
}

// What is clustered: the centroid of each occupied voxel (each distinct candidate when the voxel edge is 0),
// and the representative of each candidate (by its position in the candidate list).
void representatives(PointsView pts, const pcl::Indices& candidates, double voxel_edge, ObstacleScratch& s) {
    s.representatives->clear();
    s.representative_of.resize(candidates.size());
    if (voxel_edge > 0.0) return voxel_centroids(pts, candidates, voxel_edge, s);
    distinct_points(pts, candidates, s);
}

// Cluster id per candidate (−1: none) in s.candidate_label: the Euclidean clusters of the representatives
// (as PCL's EuclideanClusterExtraction finds them), each candidate joining its representative's; clusters outside
// the size limits (in points) dropped, the rest ranked nearest first (smallest x of their points), ties by their
// lowest input row (`row_of` each point, the point itself if null).
void candidate_labels(PointsView pts, const pcl::Indices& candidates, const ObstaclesConfig& cfg,
                      const std::vector<std::int32_t>* row_of, ObstacleScratch& s) {
    representatives(pts, candidates, cfg.voxel_m, s);
    if (!s.search || s.search_edge != cfg.cluster_tolerance_m) {
        s.search = pcl::make_shared<GridRadiusSearch>(cfg.cluster_tolerance_m);
        s.search_edge = cfg.cluster_tolerance_m;
    }
    s.search->setInputCloud(s.representatives);
    const auto components = static_cast<std::size_t>(
        euclidean_components(*s.search, cfg.cluster_tolerance_m, s.components, s.component_of));
    s.extent.assign(components, ClusterExtent{});
    s.candidate_label.resize(candidates.size());
    for (std::size_t k = 0; k < candidates.size(); ++k) {
        const std::int32_t c = s.component_of[static_cast<std::size_t>(s.representative_of[k])];
        s.candidate_label[k] = c;
        ClusterExtent& e = s.extent[static_cast<std::size_t>(c)];
        ++e.count;
        e.x_min = std::min(e.x_min, pts(candidates[k], 0));
        e.first = std::min(e.first, row_of ? (*row_of)[static_cast<std::size_t>(candidates[k])] : candidates[k]);
    }
    s.kept.clear();
    for (std::size_t c = 0; c < components; ++c)
        if (s.extent[c].count >= cfg.min_cluster_points && s.extent[c].count <= cfg.max_cluster_points)
            s.kept.push_back(static_cast<std::int32_t>(c));
    std::sort(s.kept.begin(), s.kept.end(), [&](std::int32_t a, std::int32_t b) { return s.extent[a] < s.extent[b]; });
    s.id.assign(components, -1);
    for (std::size_t rank = 0; rank < s.kept.size(); ++rank) s.id[static_cast<std::size_t>(s.kept[rank])] = static_cast<std::int32_t>(rank);
    for (auto& l : s.candidate_label) l = s.id[static_cast<std::size_t>(l)];
}

// Cluster id per point (−1: none) of the `candidates` among `points` points.
void point_labels(PointsView pts, const pcl::Indices& candidates, const ObstaclesConfig& cfg,
                  const std::vector<std::int32_t>* row_of, ObstacleScratch& s, std::vector<std::int32_t>& label) {
    label.assign(static_cast<std::size_t>(pts.rows()), -1);
    candidate_labels(pts, candidates, cfg, row_of, s);
    for (std::size_t k = 0; k < candidates.size(); ++k) label[static_cast<std::size_t>(candidates[k])] = s.candidate_label[k];
}

// Each cluster's points, ascending (counting sort): cluster g holds s.members[s.member_start[g] …
// s.member_start[g + 1]).
void group_members(const std::vector<std::int32_t>& label, std::size_t clusters, ObstacleScratch& s) {
    s.member_start.assign(clusters + 1, 0);
    for (const auto l : label)
        if (l >= 0) ++s.member_start[static_cast<std::size_t>(l) + 1];
    for (std::size_t g = 0; g < clusters; ++g) s.member_start[g + 1] += s.member_start[g];
    s.members.resize(s.member_start.back());
    s.next.assign(s.member_start.begin(), s.member_start.end() - 1);
    for (std::size_t i = 0; i < label.size(); ++i)
        if (label[i] >= 0) s.members[s.next[static_cast<std::size_t>(label[i])]++] = static_cast<pcl::index_t>(i);
}

// The box about the vertical axis along the principal horizontal directions: yaw = ½·atan2(2c_xy, c_xx − c_yy).
OrientedBox oriented_box(PointsView pts, const Members& members, const Vec3& mean) {
    double cxx = 0.0, cyy = 0.0, cxy = 0.0;
    for (const auto i : members) {
        const double dx = pts(i, 0) - mean[0], dy = pts(i, 1) - mean[1];
        cxx += dx * dx, cyy += dy * dy, cxy += dx * dy;
    }
    OrientedBox box;
    box.yaw = 0.5 * std::atan2(2.0 * cxy + 0.0, cxx - cyy);  // + 0.0: −0 would give −π/2
    const double c = std::cos(box.yaw), s = std::sin(box.yaw);
    double u_lo = kInf, u_hi = -kInf, v_lo = kInf, v_hi = -kInf, z_lo = kInf, z_hi = -kInf;
    for (const auto i : members) {
        const double dx = pts(i, 0) - mean[0], dy = pts(i, 1) - mean[1], z = pts(i, 2);
        const double u = c * dx + s * dy, v = -s * dx + c * dy;
        u_lo = std::min(u_lo, u), u_hi = std::max(u_hi, u);
        v_lo = std::min(v_lo, v), v_hi = std::max(v_hi, v);
        z_lo = std::min(z_lo, z), z_hi = std::max(z_hi, z);
    }
    const double u_mid = 0.5 * (u_lo + u_hi), v_mid = 0.5 * (v_lo + v_hi);
    box.center = {mean[0] + c * u_mid - s * v_mid, mean[1] + s * u_mid + c * v_mid, 0.5 * (z_lo + z_hi)};
    box.size = {u_hi - u_lo, v_hi - v_lo, z_hi - z_lo};
    return box;
}

// Count, centroid, axis-aligned and oriented boxes of one group.
Cluster describe(PointsView pts, const Members& members) {
    Cluster c;
    c.count = static_cast<std::int32_t>(members.size());
    c.aabb_min = {kInf, kInf, kInf};
    c.aabb_max = {-kInf, -kInf, -kInf};
    Vec3 sum{};
    for (const auto i : members) {
        for (int a = 0; a < 3; ++a) {
            const double v = pts(i, a);
            sum[a] += v;
            c.aabb_min[a] = std::min(c.aabb_min[a], v);
            c.aabb_max[a] = std::max(c.aabb_max[a], v);
        }
    }
    for (int a = 0; a < 3; ++a) c.centroid[a] = sum[a] / static_cast<double>(members.size());
    c.obb = oriented_box(pts, members, c.centroid);
    return c;
}

// Median height above the plane of the ground points within `reach` of the footprint, found in the ROI's own
// columns; 0 when there are none.
double local_ground(const RoiCloud& roi, const std::vector<std::uint8_t>& ground, const Plane& plane,
                    const Cluster& c, double reach, std::vector<double>& h) {
    const double x_lo = c.aabb_min[0] - reach, x_hi = c.aabb_max[0] + reach;
    const double y_lo = c.aabb_min[1] - reach, y_hi = c.aabb_max[1] + reach;
    const PointsView pts = roi.view();
    h.clear();
    roi.visit_columns(x_lo, x_hi, y_lo, y_hi, [&](Eigen::Index i) {
        const double x = pts(i, 0), y = pts(i, 1);
        if (ground[static_cast<std::size_t>(i)] && x >= x_lo && x <= x_hi && y >= y_lo && y <= y_hi)
            h.push_back(height_above(plane, x, y, pts(i, 2)));
    });
    return h.empty() ? 0.0 : median(h.begin(), h.end());
}

// The clusters of out.label described: boxes, local ground, height and bottom.
void describe_all(const RoiCloud& roi, const std::vector<std::uint8_t>& ground, const Plane& plane,
                  const ObstaclesConfig& cfg, ObstacleScratch& s, Clustering& out) {
    const PointsView pts = roi.view();
    group_members(out.label, s.kept.size(), s);
    const auto members_of = [&](std::size_t g) {
        return Members{s.members.data() + s.member_start[g], s.members.data() + s.member_start[g + 1]};
    };
    out.clusters.clear();
    for (std::size_t g = 0; g + 1 < s.member_start.size(); ++g) {
        out.clusters.push_back(describe(pts, members_of(g)));
        out.clusters.back().id = static_cast<std::int32_t>(g);
    }
    for (std::size_t g = 0; g < out.clusters.size(); ++g) {
        const Members members = members_of(g);
        Cluster& c = out.clusters[g];
        c.ground_offset = local_ground(roi, ground, plane, c, cfg.ground_search_m, s.heights);
        double top = -kInf, low = kInf;
        for (const auto i : members) {
            const double h = height_above(plane, pts(i, 0), pts(i, 1), pts(i, 2));
            top = std::max(top, h), low = std::min(low, h);
        }
        c.height = top - c.ground_offset;
        c.bottom = low - c.ground_offset;
    }
}

}  // namespace

ObstacleScratch::ObstacleScratch() = default;
ObstacleScratch::~ObstacleScratch() = default;

void find_obstacles(const RoiCloud& roi, const std::vector<std::uint8_t>& ground_mask, const Plane& plane,
                    const ObstaclesConfig& cfg, ObstacleScratch& s, Clustering& out) {
    s.candidates.clear();
    for (std::size_t i = 0; i < ground_mask.size(); ++i)
        if (!ground_mask[i]) s.candidates.push_back(static_cast<pcl::index_t>(i));
    point_labels(roi.view(), s.candidates, cfg, &roi.input_index, s, out.label);
    describe_all(roi, ground_mask, plane, cfg, s, out);
}

Clustering find_obstacles(const RoiCloud& roi, const std::vector<std::uint8_t>& ground_mask, const Plane& plane,
                          const ObstaclesConfig& cfg) {
    ObstacleScratch scratch;
    Clustering out;
    find_obstacles(roi, ground_mask, plane, cfg, scratch, out);
    return out;
}

Clustering find_obstacles(PointsView points, const std::vector<std::uint8_t>& ground_mask, const Plane& plane,
                          const GroundConfig& roi_cfg, const ObstaclesConfig& cfg) {
    if (ground_mask.size() != static_cast<std::size_t>(points.rows()))
        throw std::invalid_argument("ground_mask has " + std::to_string(ground_mask.size()) + " entries for " +
                                    std::to_string(points.rows()) + " points");
    RoiCloud roi;
    crop_roi(points, to_rigid_transform(Extrinsics{}), roi_cfg, roi);  // the points are in the base frame already
    std::vector<std::uint8_t> roi_ground(static_cast<std::size_t>(roi.size()));
    for (std::size_t i = 0; i < roi_ground.size(); ++i) roi_ground[i] = ground_mask[static_cast<std::size_t>(roi.input_index[i])];
    Clustering in_roi = find_obstacles(roi, roi_ground, plane, cfg);
    Clustering out;
    out.clusters = std::move(in_roi.clusters);
    out.label.assign(ground_mask.size(), -1);
    for (std::size_t i = 0; i < in_roi.label.size(); ++i) out.label[static_cast<std::size_t>(roi.input_index[i])] = in_roi.label[i];
    return out;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr cluster_representatives(PointsView points, const pcl::Indices& candidates,
                                                            double voxel_m) {
    ObstacleScratch scratch;
    representatives(points, candidates, voxel_m, scratch);
    return scratch.representatives;
}

std::vector<std::int32_t> cluster_labels(PointsView points, const ObstaclesConfig& cfg) {
    ObstacleScratch scratch;
    for (Eigen::Index i = 0; i < points.rows(); ++i)
        if (points.row(i).allFinite()) scratch.candidates.push_back(static_cast<pcl::index_t>(i));
    std::vector<std::int32_t> label;
    point_labels(points, scratch.candidates, cfg, nullptr, scratch, label);
    return label;
}

void wheel_obstacles(PointsView points, const Clustering& clustering, const Plane& plane, const Levelling& L,
                     const WheelPaths& paths, Wheel w, double tire_width, double preview_length_m,
                     const ObstaclesConfig& cfg, std::vector<PathObstacle>& out) {
    if (clustering.label.size() != static_cast<std::size_t>(points.rows()))
        throw std::invalid_argument("wheel_obstacles: " + std::to_string(clustering.label.size()) + " labels for " +
                                    std::to_string(points.rows()) + " points");
    const double corridor = tire_width + 2.0 * cfg.safety_margin_m;
    std::vector<PathObstacle>& spans = out;  // one per cluster, then compacted to those in the path
    spans.assign(clustering.clusters.size(), PathObstacle{0, kInf, -kInf, -kInf});
    for (Eigen::Index i = 0; i < points.rows(); ++i) {
        const std::int32_t id = clustering.label[static_cast<std::size_t>(i)];
        if (id < 0) continue;
        if (static_cast<std::size_t>(id) >= spans.size())
            throw std::invalid_argument("wheel_obstacles: label " + std::to_string(id) + " names no cluster");
        const double x = points(i, 0), y = points(i, 1), z = points(i, 2);
        const auto p = L.apply(x, y, z);
        const auto s = arc_length(paths, w, p[0], p[1], corridor);
        if (!s || *s >= preview_length_m) continue;
        PathObstacle& span = spans[static_cast<std::size_t>(id)];
        span.s_start = std::min(span.s_start, *s);
        span.s_end = std::max(span.s_end, *s);
        span.height = std::max(span.height, height_above(plane, x, y, z));
    }
    std::size_t kept = 0;
    for (std::size_t k = 0; k < spans.size(); ++k) {
        if (spans[k].s_start > spans[k].s_end) continue;  // no point in the corridor
        if (clustering.clusters[k].bottom > cfg.clearance_m) continue;  // overhead: canopy, sign, bridge
        const double height = spans[k].height - clustering.clusters[k].ground_offset;
        if (height < cfg.min_height_m) continue;  // ground the ground fit missed (a rising road, a ramp)
        out[kept++] = {static_cast<std::int32_t>(k), spans[k].s_start, spans[k].s_end, height};
    }
    out.resize(kept);
    // By s_start, ties by id (the order of the clusters): a stable sort, without its buffer.
    std::sort(out.begin(), out.end(), [](const PathObstacle& a, const PathObstacle& b) {
        return std::tie(a.s_start, a.id) < std::tie(b.s_start, b.id);
    });
}

std::vector<PathObstacle> wheel_obstacles(PointsView points, const Clustering& clustering, const Plane& plane,
                                          const Levelling& L, const WheelPaths& paths, Wheel w, double tire_width,
                                          double preview_length_m, const ObstaclesConfig& cfg) {
    std::vector<PathObstacle> out;
    wheel_obstacles(points, clustering, plane, L, paths, w, tire_width, preview_length_m, cfg, out);
    return out;
}

void blocked_bins(const std::vector<PathObstacle>& obstacles, std::size_t bins, double ds, double margin_m,
                  std::vector<std::uint8_t>& blocked) {
    blocked.assign(bins, 0);
    if (bins == 0) return;
    const double last = static_cast<double>(bins - 1);
    for (const PathObstacle& o : obstacles) {
        if (!(o.s_start <= o.s_end) || !std::isfinite(o.s_start) || !std::isfinite(o.s_end))
            throw std::invalid_argument("blocked_bins: an obstacle needs finite s_start <= s_end");
        // Bin k = [k·ds, (k+1)·ds) overlaps [a, b] for floor(a/ds) ≤ k ≤ floor(b/ds).
        const auto bin = [&](double s) { return static_cast<std::ptrdiff_t>(std::clamp(std::floor(s / ds), 0.0, last)); };
        std::fill(blocked.begin() + bin(o.s_start - margin_m), blocked.begin() + bin(o.s_end + margin_m) + 1, 1);
    }
}

std::vector<std::uint8_t> blocked_bins(const std::vector<PathObstacle>& obstacles, std::size_t bins, double ds,
                                       double margin_m) {
    std::vector<std::uint8_t> blocked;
    blocked_bins(obstacles, bins, ds, margin_m, blocked);
    return blocked;
}

}  // namespace roadpreview
