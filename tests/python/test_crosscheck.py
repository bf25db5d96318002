"""The C++ core and the numpy reference, run on the same inputs, must agree.

Both read the same float32 coordinates; the C++ core keeps base-frame ROI points as float32 (rounding of
~1e-7 m per metre), so decisions can only differ for points within that distance of a threshold.
"""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import roadpreview as rp
from paths import KITTI_FRAMES, KITTI_SENSOR_HEIGHT

NEAR = 1e-4  # m: points this close to a decision threshold may fall either way
STAGE_REL = 1e-9  # stage functions on the same float64 profile: measured worst 4.5e-13 (PSD), 2e-14 (confidence)


def run_both(points, speed, yaw_rate, cfg):
    cpp = rp.Estimator(cfg).process(points, speed, yaw_rate)
    ref = rp.reference.process(points, speed, yaw_rate, cfg)
    return cpp, ref


def near_a_ground_threshold(points, cfg, plane):
    """Rows within NEAR of the ROI boundary or of the PCA threshold above the (reference's) plane."""
    base, finite = rp.reference.to_base_frame(points, cfg)
    g = cfg.ground
    x, y = base[:, 0], base[:, 1]
    near = (np.abs(x - g.roi_x_min_m) < NEAR) | (np.abs(x - g.roi_x_max_m) < NEAR) | (np.abs(np.abs(y) - g.roi_y_abs_max_m) < NEAR)
    if plane is not None:
        near |= np.abs(base @ plane[:3] + plane[3] - g.pca_threshold_m) < NEAR
    out = np.zeros(len(points), bool)
    out[np.flatnonzero(finite)] = near
    return out


def assert_ground_agrees(points, cfg, cpp, ref):
    differ = cpp.ground_mask != ref.ground_mask
    assert not (differ & ~near_a_ground_threshold(points, cfg, ref.plane)).any(), f"{differ.sum()} points differ"
    assert cpp.points["input"] == ref.points["input"] and cpp.points["finite"] == ref.points["finite"]
    assert abs(cpp.points["ground"] - ref.points["ground"]) <= differ.sum()
    assert (cpp.plane is None) == (ref.plane is None)
    if ref.plane is not None:
        np.testing.assert_allclose(cpp.plane, ref.plane, atol=1e-6)


def assert_profiles_agree(cpp, ref, ground_identical):
    assert cpp.reason == ref.reason
    assert cpp.path == ref.path
    for c, r in ((cpp.left, ref.left), (cpp.right, ref.right)):
        np.testing.assert_allclose(c.s, r.s, rtol=1e-12)
        if not ground_identical:
            continue  # a point flipping ground/non-ground moves a median: compare only what both saw alike
        np.testing.assert_array_equal(c.count, r.count)
        np.testing.assert_array_equal(np.isnan(c.z), np.isnan(r.z))
        np.testing.assert_allclose(c.z, r.z, atol=1e-5, equal_nan=True)
        np.testing.assert_allclose(c.spread, r.spread, atol=1e-5, equal_nan=True)  # as z: float32 points
        assert_roughness_agrees(c.roughness, r.roughness, iri_bound(c, r))
    if ground_identical:
        bounds = [iri_bound(cpp.left, ref.left), iri_bound(cpp.right, ref.right)]
        assert_roughness_agrees(cpp.vehicle, ref.vehicle, sum(bounds) / 2)  # the vehicle's: the wheels' mean


def iri_bound(c, r) -> float:
    """How far two profiles' IRI may lie apart: the IRI filter is linear in the heights and the IRI the mean of its
    output's magnitude, so |IRI(a) − IRI(b)| ≤ IRI(a − b) — the float32 points' rounding, seen through the filter."""
    difference = rp.reference.profile_iri(np.asarray(c.z) - np.asarray(r.z), c.ds).value
    return 0.0 if difference is None else difference


def assert_roughness_agrees(c, r, iri_bound: float = 0.0, rel: float = 1e-4):
    """``rel``: the relative room of the PSD, G_d and their kin — 1e-4 for pipeline runs (float32 points); stage
    functions given the same float64 profile agree to ~1e-13 (measured), so their tests pass 1e-9."""
    assert c.reason == r.reason
    assert c.iso_class == r.iso_class or _on_a_class_limit(r.gd_n0)
    assert_support_agrees(c, r, rel)
    assert_iri_agrees(c.iri, r.iri, iri_bound)
    if r.gd_n0 is None:
        assert c.gd_n0 is None
        return
    np.testing.assert_allclose(c.n, r.n, rtol=1e-12)
    psd_atol = 1e-2 * rel * np.max(r.psd)  # float32 points: rounding-level ordinates differ in relative terms
    np.testing.assert_allclose(c.psd, r.psd, rtol=rel, atol=psd_atol)
    assert c.gd_n0 == pytest.approx(r.gd_n0, rel=rel)
    assert c.band == pytest.approx(r.band, rel=1e-12)
    assert c.band_limit == r.band_limit
    assert c.confidence == pytest.approx(r.confidence, abs=rel)
    np.testing.assert_allclose(c.octave_gd, r.octave_gd, rtol=rel, atol=psd_atol)  # means of psd ordinates
    if r.waviness is not None:
        assert c.waviness == pytest.approx(r.waviness, abs=rel)


def assert_support_agrees(c, r, rel: float = 1e-4):
    """Backed fraction, noise PSD and noise floor of the analysed stretch (None when not known)."""
    assert (c.backed_fraction is None) == (r.backed_fraction is None)
    if r.backed_fraction is not None:
        assert c.backed_fraction == pytest.approx(r.backed_fraction, rel=1e-12)
    assert (c.noise_psd is None) == (r.noise_psd is None)
    if r.noise_psd is not None:
        # Spreads agree to float32 rounding of the points (1e-8 m of spreads down to 1e-5 m): 1e-3 relative.
        np.testing.assert_allclose(c.noise_psd, r.noise_psd, rtol=10 * rel, atol=1e-5 * rel * np.max(r.noise_psd))
        assert c.noise_floor == pytest.approx(r.noise_floor, rel=10 * rel)


def assert_iri_agrees(c, r, bound: float = 0.0):
    """``bound``: m/km the two values may differ by because their profiles do (iri_bound), beyond rounding."""
    assert c.reason == r.reason
    assert (c.backed_fraction is None) == (r.backed_fraction is None)
    if r.backed_fraction is not None:
        assert c.backed_fraction == pytest.approx(r.backed_fraction, rel=1e-12)
    assert c.length == pytest.approx(r.length, rel=1e-12)
    assert (c.value is None) == (r.value is None)
    if r.value is not None:
        assert c.value == pytest.approx(r.value, rel=1e-6, abs=bound * (1 + 1e-6))


def _on_a_class_limit(gd):
    limits = 2.0 * np.asarray(rp.reference.ISO_GEOMETRIC_MEANS[:-1])
    return gd is not None and np.min(np.abs(np.log(gd / limits))) < 1e-4


@pytest.mark.parametrize("frame", KITTI_FRAMES, ids=lambda p: p.name)
@pytest.mark.parametrize("yaw_rate", [0.0, 0.15, -0.4])
def test_real_kitti_frames_agree(frame, yaw_rate):
    points = rp.io.read(frame)
    cfg = rp.Config(sensor_height=KITTI_SENSOR_HEIGHT)
    cpp, ref = run_both(points, 6.0, yaw_rate, cfg)
    assert_ground_agrees(points, cfg, cpp, ref)
    # No point of these frames lies within float32 rounding of a threshold: the same ground, so the whole profiles
    # (heights, spreads, roughness) are compared, not only their stations.
    np.testing.assert_array_equal(cpp.ground_mask, ref.ground_mask)
    assert_profiles_agree(cpp, ref, ground_identical=True)
    # Real, non-trivial profiles: a 15 m curve leaves the road early, and runs into parked cars (blocked bins).
    assert np.isfinite(cpp.left.z).sum() + cpp.left.blocked.sum() > 50
    if yaw_rate == 0.0:
        assert cpp.vehicle.iso_class is not None


def assert_same_profiles(cpp, ref, z_atol):
    """Both wheels' bins and roughness and the vehicle's, as close as rounding allows: counts and gaps equal, heights
    within `z_atol` (m; set by the caller from what it measured), spreads within 1e-6 relative."""
    assert cpp.reason == ref.reason
    for c, r in ((cpp.left, ref.left), (cpp.right, ref.right)):
        np.testing.assert_array_equal(c.count, r.count)
        np.testing.assert_array_equal(np.isnan(c.z), np.isnan(r.z))
        np.testing.assert_allclose(c.z, r.z, rtol=0, atol=z_atol, equal_nan=True)
        np.testing.assert_array_equal(np.isnan(c.spread), np.isnan(r.spread))
        np.testing.assert_allclose(c.spread, r.spread, rtol=1e-6, atol=0, equal_nan=True)
        assert_roughness_agrees(c.roughness, r.roughness, iri_bound(c, r))
    bound = (iri_bound(cpp.left, ref.left) + iri_bound(cpp.right, ref.right)) / 2  # the vehicle's: the wheels' mean
    assert_roughness_agrees(cpp.vehicle, ref.vehicle, bound)


def random_scene(rng, sensor_height, pitch, roll, obstacles, noise):
    """A sensor-frame cloud: a tilted, noisy ground seen from `sensor_height`, plus box-like obstacles. 60,000 ground
    points, 1.4 per 10-cm bin of a wheel's track: bins with two points give the spreads the noise-aware roughness
    weighs the noise by (at 15,000, 0.4 per bin, few bins had a spread and most wheels were declined)."""
    n = 60000
    x, y = rng.uniform(-5, 45, n), rng.uniform(-12, 12, n)
    z = -sensor_height + np.tan(pitch) * x + np.tan(roll) * y + rng.normal(0, noise, n)
    z += 0.02 * np.sin(0.7 * x) * np.cos(0.3 * y)
    parts = [np.column_stack([x, y, z])]
    for _ in range(obstacles):
        cx, cy, h = rng.uniform(3, 35), rng.uniform(-5, 5), rng.uniform(0.3, 2.0)
        m = 300
        parts.append(np.column_stack([cx + rng.uniform(0, 1.5, m), cy + rng.uniform(0, 1.5, m),
                                      -sensor_height + rng.uniform(0.25, h, m)]))
    pts = np.vstack(parts).astype(np.float32)
    pts[rng.random(len(pts)) < 0.01, rng.integers(0, 3)] = np.nan  # dropouts
    return pts


def test_random_scenes_agree():
    """Random scenes agree, and most driven forward with a noise the bins' points can average out (σ ≤ 1 cm) are
    classed with an IRI on both wheels: the roughness outputs are compared, not only the reasons for declining."""
    classed = []  # per forward scene with σ ≤ 1 cm: both wheels classed, with an IRI

    @settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
    @given(seed=st.integers(0, 2**31 - 1), sensor_height=st.floats(0.5, 2.5), pitch=st.floats(-0.05, 0.05),
           roll=st.floats(-0.05, 0.05), obstacles=st.integers(0, 4), noise=st.floats(0.0, 0.03),
           speed=st.sampled_from([0.0, 3.0, -2.0, 8.0, 15.0]), yaw_rate=st.floats(-0.8, 0.8), level=st.booleans())
    def agree(seed, sensor_height, pitch, roll, obstacles, noise, speed, yaw_rate, level):
        rng = np.random.default_rng(seed)
        points = random_scene(rng, sensor_height, pitch, roll, obstacles, noise)
        cfg = rp.Config(sensor_height=sensor_height, profile={"level": level})
        cpp, ref = run_both(points, speed, yaw_rate, cfg)
        assert_ground_agrees(points, cfg, cpp, ref)
        assert_profiles_agree(cpp, ref, np.array_equal(cpp.ground_mask, ref.ground_mask))
        # Reversing, the wheels' paths lie behind the sensor, outside the ground ROI (x ≥ 1 m): too short by design.
        # Noisier, most wheels are rightly declined ("noise dominates the band": 1.4 points per bin, a smooth road).
        if speed > 0 and noise <= 0.01:
            classed.append(all(w.roughness.iso_class is not None and w.roughness.iri.value is not None
                               for w in (cpp.left, cpp.right)))

    agree()
    assert len(classed) >= 15 and np.mean(classed) >= 0.75, classed  # measured: 31 of 37


def test_roughness_stage_agrees_on_random_profiles():
    """Gap filling and roughness agree, on the raw profiles (15 % NaN: mostly "valid stretch too short") and on the
    profiles filled as the pipeline fills them; those long enough are classed, so the PSD and G_d are compared too."""
    classed = []  # per profile at least min_length_m long: classed

    @settings(max_examples=40, deadline=None)
    @given(seed=st.integers(0, 2**31 - 1), count=st.integers(2, 600), ds=st.sampled_from([0.05, 0.1, 0.25]),
           gap=st.floats(0.0, 0.6))
    def agree(seed, count, ds, gap):
        rng = np.random.default_rng(seed)
        z = np.cumsum(rng.normal(0, 0.003, count))
        z[rng.random(count) < 0.15] = np.nan
        cfg = rp.Config()
        filled_cpp, filled_ref = rp.native.fill_gaps(z, ds, gap), rp.reference.fill_gaps(z, ds, gap)
        np.testing.assert_array_equal(np.isnan(filled_cpp), np.isnan(filled_ref))
        np.testing.assert_allclose(filled_cpp, filled_ref, rtol=1e-14, atol=1e-15, equal_nan=True)  # rounding only
        assert rp.native.longest_valid_stretch(z) == rp.reference.longest_valid_stretch(z)
        assert_roughness_agrees(rp.native.analyze_roughness(z, ds, cfg), rp.reference.analyze_roughness(z, ds, cfg),
                                rel=STAGE_REL)
        filled = rp.reference.fill_gaps(z, ds, cfg.profile.max_gap_m)  # gaps up to 1 m, as the pipeline's
        got = rp.native.analyze_roughness(filled, ds, cfg)
        assert_roughness_agrees(got, rp.reference.analyze_roughness(filled, ds, cfg), rel=STAGE_REL)
        if count * ds >= cfg.roughness.min_length_m:
            classed.append(got.iso_class is not None)

    agree()
    assert len(classed) >= 15 and np.mean(classed) >= 0.9, classed  # measured: 22 of 22


def random_support(rng, count_bins):
    """Point counts (with empty bins) and spreads as the profile stage makes them (NaN below 2 points)."""
    count = rng.choice([0, 0, 1, 2, 3, 8, 20], size=count_bins).astype(np.int32)
    count[[0, -1]] = np.maximum(count[[0, -1]], 1)  # a stretch starts and ends on points
    spread = np.where(count >= 2, rng.uniform(0.0, 0.02, count_bins), np.nan)
    return count, spread


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), count=st.integers(50, 500), gd_exponent=st.integers(0, 7),
       noise_aware=st.booleans())
def test_noise_aware_roughness_agrees_on_random_profiles(seed, count, gd_exponent, noise_aware):
    rng = np.random.default_rng(seed)
    n = np.arange(count // 2 + 1) / (count * 0.1)
    psd = np.zeros_like(n)
    psd[1:-1] = 16e-6 * 4.0**gd_exponent * (n[1:-1] / 0.1) ** -2
    z = np.fft.irfft(np.sqrt(psd * count / 0.2) * (rng.standard_normal(len(n)) + 1j * rng.standard_normal(len(n))) / np.sqrt(2), n=count)
    counts, spread = random_support(rng, count)
    z = rp.reference.fill_gaps(np.where(counts > 0, z, np.nan), 0.1, 10.0)
    cfg = rp.Config(roughness={"noise_aware": noise_aware})
    support = {"count": counts, "spread": spread}
    assert_roughness_agrees(rp.native.analyze_roughness(z, 0.1, cfg, **support),
                            rp.reference.analyze_roughness(z, 0.1, cfg, **support), rel=STAGE_REL)
    np.testing.assert_allclose(rp.native.noise_psd(counts, spread, 0.1), rp.reference.noise_psd(counts, spread, 0.1),
                               rtol=1e-9)
    np.testing.assert_allclose(rp.native.resolved_fraction(counts, 0.1, n), rp.reference.resolved_fraction(counts, 0.1, n),
                               rtol=1e-12, atol=1e-15)
    other = np.roll(z, 7)
    both = {"count_left": counts, "spread_left": spread, "count_right": counts[::-1].copy(), "spread_right": spread[::-1].copy()}
    assert_roughness_agrees(rp.native.vehicle_roughness(z, other, 0.1, cfg, **both),
                            rp.reference.vehicle_roughness(z, other, 0.1, cfg, **both), rel=STAGE_REL)
