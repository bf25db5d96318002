// Benchmark of the search behind the obstacle stage's clustering: PCL's EuclideanClusterExtraction over the
// points the stage clusters (the 0.25 m voxel centroids of each KITTI frame's non-ground front-region points,
// `pca` ground; and every point), with each pcl::search::Search implementation in turn, single-threaded.
//
// Prints a Markdown table on stdout: per frame and search, median (min–max) ms of --repeat runs after one
// warm-up (the search's setInputCloud and the extraction, as the stage runs them), the ratio to PCL's KdTree in
// the same run, the number of clusters and whether they are the KdTree's.
//
// Built with the C++ tests (it needs the internal grid search and PCL):
//   build/ctest/tests/cluster_search_bench [--repeat N] [--quick] [KITTI_DIR]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include <pcl/search/flann_search.h>
#include <pcl/search/kdtree.h>
#include <pcl/search/octree.h>
#include <pcl/segmentation/extract_clusters.h>

#include <roadpreview/roadpreview.hpp>

#include "obstacles/grid_radius_search.hpp"
#include "obstacles/obstacles_pcl.hpp"

namespace rp = roadpreview;
namespace fs = std::filesystem;

namespace {

using Cloud = pcl::PointCloud<pcl::PointXYZ>;
using SearchPtr = pcl::search::Search<pcl::PointXYZ>::Ptr;
using Points = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;

constexpr double kSensorHeight = 1.73;  // KITTI's HDL-64E, as bench/obstacles.py

struct Variant {
    std::string name;
    std::function<SearchPtr()> make;
};

std::vector<Variant> variants(double tolerance) {
    using Flann = pcl::search::FlannSearch<pcl::PointXYZ>;
    return {
        {"pcl::search::KdTree (before)", [] { return pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>(false); }},
        {"pcl::search::FlannSearch, k-d tree, 15 per leaf",
         [] { return pcl::make_shared<Flann>(false, pcl::make_shared<Flann::KdTreeIndexCreator>(15)); }},
        {"pcl::search::Octree, 0.25 m", [] { return pcl::make_shared<pcl::search::Octree<pcl::PointXYZ>>(0.25); }},
        {"pcl::search::Octree, 0.5 m", [] { return pcl::make_shared<pcl::search::Octree<pcl::PointXYZ>>(0.5); }},
        {"pcl::search::Octree, 1 m", [] { return pcl::make_shared<pcl::search::Octree<pcl::PointXYZ>>(1.0); }},
        {"GridRadiusSearch (now)", [tolerance] { return pcl::make_shared<rp::GridRadiusSearch>(tolerance); }},
    };
}

// The non-ground front-region points of a KITTI frame in the base frame, as the pipeline's obstacle stage sees them.
Points candidates_of(const fs::path& bin, const rp::Config& cfg) {
    const rp::Frame frame = rp::read_frame(bin.string());
    rp::Estimator est(cfg);
    const rp::Result r = est.process(frame.points, 5.0, 0.1);
    const auto& g = cfg.ground;
    std::vector<Eigen::Index> rows;
    for (Eigen::Index i = 0; i < frame.points.rows(); ++i) {
        const float x = frame.points(i, 0), y = frame.points(i, 1);
        if (!r.ground_mask[static_cast<std::size_t>(i)] && frame.points.row(i).head<3>().allFinite() &&
            x >= g.roi_x_min_m && x <= g.roi_x_max_m && std::abs(y) <= g.roi_y_abs_max_m)
            rows.push_back(i);
    }
    Points out(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t k = 0; k < rows.size(); ++k) {
        out.row(static_cast<Eigen::Index>(k)) = frame.points.row(rows[k]).head<3>();
        out(static_cast<Eigen::Index>(k), 2) += static_cast<float>(kSensorHeight);
    }
    return out;
}

std::vector<pcl::Indices> clusters(const Cloud::Ptr& cloud, const SearchPtr& search, double tolerance) {
    pcl::EuclideanClusterExtraction<pcl::PointXYZ> extraction;
    extraction.setSearchMethod(search);
    extraction.setClusterTolerance(tolerance);
    extraction.setInputCloud(cloud);
    std::vector<pcl::PointIndices> found;
    extraction.extract(found);
    std::vector<pcl::Indices> out;
    for (auto& c : found) out.push_back(std::move(c.indices));
    std::sort(out.begin(), out.end());
    return out;
}

struct Timing {
    double median, min, max;
    std::vector<pcl::Indices> clusters;
};

Timing time_variant(const Cloud::Ptr& cloud, const Variant& v, double tolerance, int repeat) {
    Timing t{0, 0, 0, clusters(cloud, v.make(), tolerance)};  // warm-up
    std::vector<double> ms;
    for (int r = 0; r < repeat; ++r) {
        const auto start = std::chrono::steady_clock::now();
        clusters(cloud, v.make(), tolerance);
        ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    }
    std::sort(ms.begin(), ms.end());
    t.median = ms[ms.size() / 2], t.min = ms.front(), t.max = ms.back();
    return t;
}

}  // namespace

int main(int argc, char** argv) {
    int repeat = 30;
    fs::path dir = ROADPREVIEW_TEST_DATA "/semantickitti";
    for (int a = 1; a < argc; ++a) {
        const std::string arg = argv[a];
        if (arg == "--quick") {
            repeat = 3;
        } else if (arg == "--repeat" && a + 1 < argc) {
            repeat = std::max(1, std::atoi(argv[++a]));
        } else if (arg.rfind("--", 0) == 0) {
            std::fprintf(stderr, "usage: %s [--repeat N] [--quick] [KITTI_DIR]\n", argv[0]);
            return 2;
        } else {
            dir = arg;
        }
    }
    std::vector<fs::path> bins;
    for (const auto& e : fs::directory_iterator(dir))
        if (e.path().extension() == ".bin") bins.push_back(e.path());
    std::sort(bins.begin(), bins.end());
    if (bins.empty()) {
        std::fprintf(stderr, "cluster_search_bench: no .bin frame in %s\n", dir.c_str());
        return 1;
    }
    rp::Config cfg;
    cfg.sensor_height = kSensorHeight;
    const double tolerance = cfg.obstacles.cluster_tolerance_m;
    std::printf("| frame | clustered | points | search | ms | × KdTree | clusters | same as KdTree |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (const auto& bin : bins) {
        const Points pts = candidates_of(bin, cfg);
        pcl::Indices all(static_cast<std::size_t>(pts.rows()));
        for (std::size_t k = 0; k < all.size(); ++k) all[k] = static_cast<pcl::index_t>(k);
        const rp::PointsView view = rp::points_view(pts.data(), pts.rows(), 3);
        for (const double voxel : {cfg.obstacles.voxel_m, 0.0}) {
            const Cloud::Ptr cloud = rp::cluster_representatives(view, all, voxel);
            Timing kdtree{};
            for (const Variant& v : variants(tolerance)) {
                const bool kd = v.name.rfind("pcl::search::KdTree", 0) == 0, grid = v.name.rfind("Grid", 0) == 0;
                if (voxel == 0.0 && !kd && !grid) continue;  // every point: the two that matter, ≈ 50 ms a run
                const Timing t = time_variant(cloud, v, tolerance, voxel == 0.0 ? std::max(1, repeat / 6) : repeat);
                if (kd) kdtree = t;
                std::printf("| %s | %s | %zu | %s | %.2f (%.2f–%.2f) | %.2f | %zu | %s |\n", bin.stem().c_str(),
                            voxel > 0 ? "voxel centroids" : "every point", cloud->size(), v.name.c_str(), t.median,
                            t.min, t.max, t.median / kdtree.median, t.clusters.size(),
                            t.clusters == kdtree.clusters ? "yes" : "NO");
                std::fflush(stdout);
            }
        }
    }
    return 0;
}
