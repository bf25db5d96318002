// SPDX-License-Identifier: BSD-3-Clause
// The route's files: the segments CSV, each wheel's stitched profile as CSV and in the ERD text format.
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "roadpreview/route/route.hpp"

namespace roadpreview {
namespace {

// printf-style formatting of one number; an empty field for NaN or a missing value.
std::string field(const char* format, double v) {
    if (!std::isfinite(v)) return "";
    char buf[64];
    std::snprintf(buf, sizeof buf, format, v);
    return buf;
}

std::string field(const char* format, const std::optional<double>& v) { return v ? field(format, *v) : ""; }

// A text field, quoted when it holds a comma or a quote (RFC 4180).
std::string text(const std::string& s) {
    if (s.find_first_of(",\"\n") == std::string::npos) return s;
    std::string out = "\"";
    for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

std::string class_of(const Roughness& r) { return r.iso_class ? std::string(1, *r.iso_class) : ""; }

std::optional<double> gd_n0_of(const Roughness& r) {
    return r.iso_class ? std::optional<double>(r.gd_n0) : std::nullopt;
}

constexpr const char* kSides[] = {"left", "right", "vehicle"};

}  // namespace

void write_segments_csv(std::ostream& out, const std::vector<RouteSegment>& segments) {
    out << "segment_length_m,start_m,end_m,x_start_m,y_start_m,x_end_m,y_end_m";
    for (const char* prefix :
         {"class_", "gd_n0_m3_", "iri_m_per_km_", "backed_fraction_", "class_reason_", "iri_reason_",
          "iri_noise_m_per_km_"})
        for (const char* side : kSides) out << ',' << prefix << side;
    out << '\n';
    for (const RouteSegment& s : segments) {
        const auto xy = [](const std::optional<Pose2>& p, bool y) {
            return p ? field("%.3f", y ? p->y_m : p->x_m) : std::string();
        };
        out << field("%g", s.length_m) << ',' << field("%.2f", s.start_m) << ',' << field("%.2f", s.end_m) << ','
            << xy(s.start, false) << ',' << xy(s.start, true) << ',' << xy(s.end, false) << ',' << xy(s.end, true);
        const SegmentWheel* sides[] = {&s.left, &s.right, &s.vehicle};
        for (const auto* w : sides) out << ',' << class_of(w->roughness);
        for (const auto* w : sides) out << ',' << field("%.6g", gd_n0_of(w->roughness));
        for (const auto* w : sides) out << ',' << field("%.4f", w->iri.value);
        for (const auto* w : sides) out << ',' << field("%.4f", w->backed_fraction);
        for (const auto* w : sides) out << ',' << text(w->roughness.iso_class ? "" : to_string(w->roughness.reason));
        for (const auto* w : sides) out << ',' << text(to_string(w->iri.reason));
        for (const auto* w : sides) out << ',' << field("%.4f", w->iri.noise);
        out << '\n';
    }
    if (!out) throw std::runtime_error("segments CSV: write failed");
}

void write_profile_csv(std::ostream& out, const StitchedProfile& p) {
    out << "distance_m,z_m,count,frames,filled,blocked\n";
    for (std::size_t j = 0; j < p.z.size(); ++j) {
        const bool filled = p.count[j] == 0 && std::isfinite(p.z[j]);
        const bool blocked = j < p.blocked.size() && p.blocked[j];
        out << field("%.2f", (static_cast<double>(j) + 0.5) * p.ds) << ',' << field("%.5f", p.z[j]) << ','
            << p.count[j] << ',' << p.frames[j] << ',' << (filled ? 1 : 0) << ',' << (blocked ? 1 : 0) << '\n';
    }
    if (!out) throw std::runtime_error("profile CSV: write failed");
}

// Header as in the LTPP profile files ProVAL imports: the format line (channels, samples per channel, −1, 1,
// 5, sample interval, −1), then keyword lines whose keyword fills the first 8 columns, then END.
void write_profile_erd(std::ostream& out, const StitchedProfile& p, const std::string& wheel,
                       const std::string& title) {
    const auto [first, last] = longest_valid_stretch(p.z);
    if (last - first < 2)
        throw std::runtime_error("ERD export: the " + wheel + " wheel's stitched profile has no valid stretch");
    char line[128];
    std::snprintf(line, sizeof line, "%7d,%8zu,%7d,%7d,%7d,%13.4f,%7d,", 1, last - first, -1, 1, 5, p.ds, -1);
    const double start_m = static_cast<double>(first) * p.ds + 0.5 * p.ds;
    out << "ERDFILEV2.00\n" << line << '\n';
    out << "TITLE   " << title << ": " << wheel << " wheel path from " << field("%.2f", start_m)
        << " m along the drive\n";
    std::snprintf(line, sizeof line, "SHORTNAM%-8s\nUNITSNAM%-8s\nXUNITS  m\nEND\n", wheel.c_str(), "mm");
    out << line;
    for (std::size_t j = first; j < last; ++j) out << field("%.3f", 1000.0 * p.z[j]) << '\n';
    if (!out) throw std::runtime_error("ERD export: write failed");
}

}  // namespace roadpreview
