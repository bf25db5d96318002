// Synthetic scenes with known answers, shared by the C++ tests.
#pragma once

#include <cmath>
#include <random>
#include <vector>

#include <roadpreview/roadpreview.hpp>

namespace scenes {

using Cloud = Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor>;

/// Points on the plane z = a·x + b·y + c over x ∈ [x0, x1], |y| ≤ half_width, on a jittered grid.
inline Cloud plane(double a, double b, double c, int n, double x0 = 1.0, double x1 = 40.0, double half_width = 9.0,
                   unsigned seed = 1) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> ux(x0, x1), uy(-half_width, half_width);
    Cloud pts(n, 3);
    for (int i = 0; i < n; ++i) {
        const double x = ux(rng), y = uy(rng);
        pts.row(i) << float(x), float(y), float(a * x + b * y + c);
    }
    return pts;
}

/// Stacks two clouds.
inline Cloud concat(const Cloud& a, const Cloud& b) {
    Cloud out(a.rows() + b.rows(), 3);
    out << a, b;
    return out;
}

/// Points on the top and the four sides of a box standing on z = z0, turned by `yaw` about its centre (cx, cy),
/// `step` apart on each face (no bottom face: it lies on the ground).
inline Cloud box(double cx, double cy, double length, double width, double height, double z0 = 0.0, double yaw = 0.0,
                 double step = 0.05) {
    std::vector<Eigen::Vector3d> local;  // box frame: centre of the footprint at the origin
    const auto span = [step](double extent) { return std::max(1, static_cast<int>(std::ceil(extent / step))); };
    const int nl = span(length), nw = span(width), nh = span(height);
    for (int i = 0; i <= nl; ++i)
        for (int j = 0; j <= nw; ++j) local.emplace_back(length * i / nl - length / 2, width * j / nw - width / 2, height);
    for (int k = 0; k < nh; ++k) {
        const double z = height * k / nh;
        for (int i = 0; i <= nl; ++i)
            for (double side : {-width / 2, width / 2}) local.emplace_back(length * i / nl - length / 2, side, z);
        for (int j = 1; j < nw; ++j)
            for (double end : {-length / 2, length / 2}) local.emplace_back(end, width * j / nw - width / 2, z);
    }
    Cloud pts(static_cast<Eigen::Index>(local.size()), 3);
    const double c = std::cos(yaw), s = std::sin(yaw);
    for (std::size_t n = 0; n < local.size(); ++n) {
        const Eigen::Vector3d& p = local[n];
        pts.row(static_cast<Eigen::Index>(n)) << float(cx + c * p.x() - s * p.y()), float(cy + s * p.x() + c * p.y()),
            float(z0 + p.z());
    }
    return pts;
}

/// A Gaussian random profile with the one-sided PSD G(n) = gd_n0 (n/0.1)^-2 (ISO 8608, w = 2).
inline std::vector<double> iso_profile(double gd_n0, std::size_t samples, double ds, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> gauss(0.0, 1.0);
    const double length = samples * ds;
    std::vector<double> z(samples, 0.0);
    for (std::size_t k = 1; k < samples / 2; ++k) {
        const double n = k / length, g = gd_n0 * std::pow(n / 0.1, -2.0);
        // A cosine and a sine of variance G·Δn each give the band's variance G·Δn in expectation.
        const double a = gauss(rng) * std::sqrt(g / length), b = gauss(rng) * std::sqrt(g / length);
        for (std::size_t j = 0; j < samples; ++j) {
            const double phase = 2.0 * M_PI * k * j / samples;
            z[j] += a * std::cos(phase) + b * std::sin(phase);
        }
    }
    return z;
}

}  // namespace scenes
