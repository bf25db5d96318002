#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <roadpreview/core/config.hpp>

namespace rp = roadpreview;

TEST(Config, DefaultsAreThePapers) {
    const rp::Config c;
    EXPECT_EQ(c.ground.method, rp::GroundMethod::Zones);  // the paper's fit per patch (method.md §1)
    EXPECT_DOUBLE_EQ(c.ground.max_tilt_deg, 15.0);
    EXPECT_DOUBLE_EQ(c.ground.pca_threshold_m, 0.20);
    EXPECT_EQ(c.ground.pca_iterations, 3);
    EXPECT_DOUBLE_EQ(c.profile.ds_m, 0.1);
    EXPECT_DOUBLE_EQ(c.roughness.band_min_cpm, 0.1);
    EXPECT_DOUBLE_EQ(c.roughness.band_max_cpm, 4.0);
    EXPECT_NO_THROW(rp::validate(c));
}

TEST(Config, JsonRoundTripKeepsEveryField) {
    rp::Config c;
    c.extrinsics = rp::Extrinsics{0.1, 0.2, 1.9, 0.01, -0.02, 0.03};
    c.track_width = 1.7;
    c.ground.method = rp::GroundMethod::Ransac;
    c.ground.ransac_seed = 42;
    c.profile.level = false;
    c.roughness.min_band_points = 9;
    c.obstacles.enabled = false;
    c.obstacles.cluster_tolerance_m = 0.3;
    const rp::Config back = rp::config_from_json(rp::config_to_json(c));
    EXPECT_EQ(rp::config_to_json(back), rp::config_to_json(c));
    EXPECT_DOUBLE_EQ(back.extrinsics->pitch_rad, -0.02);
    EXPECT_EQ(back.ground.method, rp::GroundMethod::Ransac);
    EXPECT_FALSE(back.obstacles.enabled);
    EXPECT_DOUBLE_EQ(back.obstacles.cluster_tolerance_m, 0.3);
}

TEST(Config, MissingFieldsKeepDefaults) {
    const rp::Config c = rp::config_from_json(R"({"sensor_height": 1.73, "ground": {"method": "ransac"}})");
    EXPECT_DOUBLE_EQ(*c.sensor_height, 1.73);
    EXPECT_EQ(c.ground.method, rp::GroundMethod::Ransac);
    EXPECT_DOUBLE_EQ(c.ground.roi_x_max_m, 40.0);
    EXPECT_DOUBLE_EQ(c.track_width, 1.6);
}

void expect_rejected(const std::string& json, const std::string& words) {
    try {
        rp::config_from_json(json, "my.json");
        FAIL() << "accepted " << json;
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("my.json"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
}

void expect_rejected_file(const std::string& path, const std::string& words) {
    try {
        rp::config_from_file(path);
        FAIL() << "accepted " << path;
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
}

TEST(Config, BadFilesAreRejectedWithTheFieldNamed) {
    expect_rejected(R"({"trackwidth": 1.6})", "trackwidth");
    expect_rejected(R"({"ground": {"methdo": "pca"}})", "ground.methdo");
    expect_rejected(R"({"extrinsics": {"x": 1}})", "extrinsics.x");
    expect_rejected(R"({"ground": {"method": "lidar"}})", "ground.method");
    expect_rejected(R"({"track_width": -1})", "track_width");
    expect_rejected(R"({"track_width": "wide"})", "track_width");
    expect_rejected(R"({"sensor_height": 1.7, "extrinsics": {"z_m": 1.7}})", "not both");
    expect_rejected(R"({"profile": {"ds_m": 0}})", "profile.ds_m");
    expect_rejected(R"({"roughness": {"band_min_cpm": 5, "band_max_cpm": 4}})", "band_min_cpm");
    expect_rejected(R"({"obstacles": {"cluster_tolerance_m": 0}})", "obstacles.cluster_tolerance_m");
    expect_rejected(R"({"obstacles": {"voxel_m": 0.001}})", "obstacles.voxel_m");
    expect_rejected(R"({"ground": {"zone_min_breadth_m": -0.1}})", "ground.zone_min_breadth_m");
    // Integers beyond their type: nlohmann would cast them unchecked (undefined behaviour).
    expect_rejected(R"({"ground": {"pca_iterations": 1e83}})", "ground.pca_iterations must be a whole number from");
    expect_rejected(R"({"ground": {"ransac_seed": -1}})", "ground.ransac_seed must be a whole number from 0 to");
    expect_rejected(R"({"ground": {"zone_sectors": [16, 1e83]}})", "ground.zone_sectors must hold whole numbers from");
    expect_rejected(R"({"ground": {"zone_sectors": [16, 2.5]}})", "ground.zone_sectors must hold whole numbers from");
    expect_rejected(R"({"obstacles": {"min_cluster_points": 10, "max_cluster_points": 5}})", "obstacles.max_cluster_points");
    expect_rejected(R"({"obstacles": {"safety_margin_m": -0.1}})", "obstacles.safety_margin_m");
    expect_rejected(R"({"obstacles": {"tolerance": 0.5}})", "obstacles.tolerance");
    expect_rejected(R"([1, 2])", "object");
    expect_rejected(R"({"track_width": )", "parse");
}

TEST(Config, EffectiveExtrinsics) {
    rp::Config c;
    EXPECT_DOUBLE_EQ(rp::effective_extrinsics(c).z_m, 0.0);
    c.sensor_height = 1.73;
    EXPECT_DOUBLE_EQ(rp::effective_extrinsics(c).z_m, 1.73);
}

TEST(Config, YamlAndJsonFilesGiveTheSameConfig) {
    const auto dir = std::filesystem::temp_directory_path();
    const auto yaml = (dir / "roadpreview_cfg.yaml").string(), json = (dir / "roadpreview_cfg.json").string();
    std::ofstream(yaml) << "sensor_height: 1.73\nground:\n  method: ransac\n  ransac_seed: 7\nprofile:\n  level: false\n";
    std::ofstream(json) << R"({"sensor_height": 1.73, "ground": {"method": "ransac", "ransac_seed": 7},
                             "profile": {"level": false}})";
    EXPECT_EQ(rp::config_to_json(rp::config_from_file(yaml)), rp::config_to_json(rp::config_from_file(json)));
    std::ofstream(yaml) << "ground: [unclosed\n";
    EXPECT_THROW(rp::config_from_file(yaml), std::invalid_argument);
    std::ofstream(yaml) << "track_width: wide\n";
    expect_rejected_file(yaml, "track_width");
    std::ofstream(yaml) << "sensor_height: 1\xd8\xc8" "3\nground:\n  method: ransac\n";  // found by config_fuzz
    expect_rejected_file(yaml, "not UTF-8");
    EXPECT_THROW(rp::config_from_file((dir / "absent.yaml").string()), std::invalid_argument);
}

TEST(Config, TheTiltLimitsOldNameIsStillRead) {
    EXPECT_DOUBLE_EQ(rp::config_from_json(R"({"ground": {"ransac_max_tilt_deg": 12}})").ground.max_tilt_deg, 12.0);
    EXPECT_THROW(rp::config_from_json(R"({"ground": {"ransac_max_tilt_deg": 12, "max_tilt_deg": 10}})"),
                 std::invalid_argument);
    EXPECT_THROW(rp::config_from_json(R"({"ground": {"max_tilt_deg": 90}})"), std::invalid_argument);
    EXPECT_THROW(rp::config_from_json(R"({"ground": {"zone_sectors": [4, 4]}})"), std::invalid_argument);  // 14 rings
}

TEST(Config, TheZoneModelsPatchesAreBounded) {  // 1000 rings of 100000 sectors once asked for gigabytes a frame
    const auto zones = [](int rings) {  // `rings` rings of 100000 sectors each
        std::string edges = "0", sectors;
        for (int ring = 1; ring <= rings; ++ring) {
            edges += "," + std::to_string(ring);
            sectors += std::string(ring > 1 ? "," : "") + "100000";
        }
        return R"({"ground": {"zone_ring_edges_m": [)" + edges + R"(], "zone_sectors": [)" + sectors + "]}}";
    };
    rp::config_from_json(zones(10));  // a million patches: the most
    try {
        rp::config_from_json(zones(11));
        FAIL() << "1.1 million patches accepted";
    } catch (const std::invalid_argument& e) {
        EXPECT_NE(std::string(e.what()).find("ground.zone_sectors must sum to at most 1000000 patches"),
                  std::string::npos) << e.what();
    }
}

// An enum made from an integer names no method: refused, not run as some method unsaid; check_config says the same
// without throwing.
TEST(Config, AMethodOutsideTheEnumIsRefused) {
    rp::Config cfg;
    cfg.ground.method = static_cast<rp::GroundMethod>(7);
    EXPECT_THROW(rp::validate(cfg), std::invalid_argument);
    rp::Status s = rp::check_config(cfg);
    EXPECT_EQ(s.code(), rp::StatusCode::InvalidArgument);
    EXPECT_STREQ(s.message(), "invalid config: ground.method must be pca, ransac or zones, got the value 7");
    cfg = rp::Config{};
    cfg.fusion.method = static_cast<rp::FusionMethod>(-1);
    EXPECT_STREQ(rp::check_config(cfg).message(), "invalid config: fusion.method must be none, ema or kalman, got the value -1");
    EXPECT_TRUE(rp::check_config(rp::Config{}).ok());
}
