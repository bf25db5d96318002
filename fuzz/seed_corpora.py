#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Writes a seed corpus per fuzz target from the real files in tests/data (stdlib only).

Usage: seed_corpora.py TESTS_DATA_DIR OUT_DIR  → OUT_DIR/<target>/seed_*. Seeds are kept small (a few kB to
64 kB) so libFuzzer spends its time mutating structure, not copying megabytes.
"""
import json
import struct
import sys
import zlib
from pathlib import Path

MAX_SEED_BYTES = 60_000


def pcap_records(data):
    """(header bytes, [record bytes]) of a classic little-endian pcap."""
    records, off = [], 24
    while off + 16 <= len(data):
        incl = struct.unpack_from("<I", data, off + 8)[0]
        records.append(data[off: off + 16 + incl])
        off += 16 + incl
    return data[:24], records


def leading_records(path, budget=MAX_SEED_BYTES):
    header, records = pcap_records(path.read_bytes())
    out = bytearray(header)
    for rec in records:
        if len(out) + len(rec) > budget:
            break
        out += rec
    return bytes(out)


def packet_decoder_seeds(data_dir):
    picks = {0: "ouster/OS-1-32-G_v2.1.1_1024x10.pcap", 3: "ouster/OS-1-128_v2.3.0_1024x10_lb_n3.pcap",
             5: "velodyne/velodyne_example.pcap", 7: "velodyne/hdl32_example.pcap"}
    for pick, name in picks.items():
        _, records = pcap_records((data_dir / name).read_bytes())
        payloads = [rec[16 + 42:] for rec in records if len(rec) > 16 + 42 + 1000][:4]
        for n, payload in enumerate(payloads):
            yield f"{pick}_{n}", bytes([pick, 1]) + payload


def pcapng_block(kind, body):
    """One pcapng block: type, total length, body padded to 4 bytes, total length again (little endian)."""
    body += b"\0" * (-len(body) % 4)
    return struct.pack("<II", kind, len(body) + 12) + body + struct.pack("<I", len(body) + 12)


def as_pcapng(pcap):
    """The same records as a pcapng: section header, one interface (the pcap's link type), enhanced packets."""
    header, records = pcap_records(pcap)
    link_type = struct.unpack_from("<I", header, 20)[0]
    out = pcapng_block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))
    out += pcapng_block(1, struct.pack("<HHI", link_type, 0, 65535))
    for rec in records:
        sec, usec, incl, orig = struct.unpack_from("<IIII", rec)
        stamp = sec * 1_000_000 + usec
        out += pcapng_block(6, struct.pack("<IIIII", 0, stamp >> 32, stamp & 0xFFFFFFFF, incl, orig) + rec[16:])
    return out


def pcap_seeds(data_dir):
    ouster = leading_records(data_dir / "ouster/OS-1-32-G_v2.1.1_1024x10.pcap")
    yield "ouster_os1_32", b"\x01" + ouster
    yield "ouster_os1_32_pcapng", b"\x01" + as_pcapng(ouster)
    for name in ("velodyne_example", "hdl32_example", "velodyne_vlp16"):
        velodyne = leading_records(data_dir / f"velodyne/{name}.pcap")
        yield name, b"\x00" + velodyne
    yield "velodyne_vlp16_pcapng", b"\x00" + as_pcapng(velodyne)


def pcd_text(fields, count, encoding):
    header = (f"# .PCD v0.7\nVERSION 0.7\nFIELDS {' '.join(fields)}\nSIZE {' '.join('4' * len(fields))}\n"
              f"TYPE {' '.join('F' * len(fields))}\nCOUNT {' '.join('1' * len(fields))}\nWIDTH {count}\n"
              f"HEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {count}\nDATA {encoding}\n")
    return header.encode()


def lzf_literals(raw):
    """An LZF stream of literal runs only (control byte n < 32: n + 1 literal bytes follow): valid, uncompressed."""
    out = bytearray()
    for at in range(0, len(raw), 32):
        chunk = raw[at: at + 32]
        out += bytes([len(chunk) - 1]) + chunk
    return bytes(out)


def kitti_rows(data_dir, count=64):
    kitti = (data_dir / "semantickitti/000000.bin").read_bytes()[: count * 16]
    return kitti, [struct.unpack_from("<4f", kitti, 16 * i) for i in range(count)]


def pcd_seeds(data_dir):
    kitti, rows = kitti_rows(data_dir)
    fields = ["x", "y", "z", "intensity"]
    yield "ascii", pcd_text(fields, 64, "ascii") + "".join(" ".join(f"{v:.4f}" for v in r) + "\n" for r in rows).encode()
    yield "binary", pcd_text(fields, 64, "binary") + kitti
    soa = b"".join(struct.pack(f"<{len(rows)}f", *[r[k] for r in rows]) for k in range(4))  # field by field
    packed = lzf_literals(soa)
    yield "binary_compressed", pcd_text(fields, 64, "binary_compressed") + struct.pack("<II", len(packed), len(soa)) + packed
    real = (data_dir / "pcd/patchwork_128ring_000000.pcd").read_bytes()
    yield "real_head", real[:4096]


def ply_seeds(data_dir):
    kitti, rows = kitti_rows(data_dir)
    fields = "".join(f"property float {name}\n" for name in ("x", "y", "z", "intensity"))

    def header(encoding):
        return f"ply\nformat {encoding} 1.0\nelement vertex {len(rows)}\n{fields}end_header\n".encode()
    yield "ascii", header("ascii") + "".join(" ".join(f"{v:.4f}" for v in r) + "\n" for r in rows).encode()
    yield "binary_little_endian", header("binary_little_endian") + kitti
    yield "binary_big_endian", header("binary_big_endian") + b"".join(struct.pack(">4f", *r) for r in rows)
    with_face = header("ascii").replace(b"end_header", b"element face 1\nproperty list uchar int vertex_indices\n"
                                                       b"end_header")
    yield "face", with_face + b"".join(b"%.4f %.4f %.4f %.4f\n" % r for r in rows) + b"3 0 1 2\n"
    # As PCL writes an organized cloud: obj_info dimensions (PCL sizes the cloud by them) and a range grid.
    organized = header("binary_little_endian").replace(
        b"element vertex", b"obj_info num_cols 8\nobj_info num_rows 8\nelement vertex").replace(
        b"end_header", b"element range_grid 64\nproperty list uchar int vertex_indices\nend_header")
    yield "range_grid", organized + kitti + b"".join(struct.pack("<Bi", 1, i) for i in range(len(rows)))


def beams_seeds():
    """Beams files as `roadpreview calibrate` writes them (docs/output.md, "Beams file"): by decoder, by elevation."""
    def beams(count, elevation):
        return "".join(f"  - {{beam: {b}, determined: {str(b % 3 > 0).lower()}, elevation_offset_deg: {0.01 * b}, "
                       f"elevation_sigma_deg: {'0.002' if b % 3 else 'null'}, range_offset_m: 0, range_sigma_m: null, "
                       f"observations: {120 * b}" + (f", elevation_deg: {2.0 - 0.4 * b}" if elevation else "") + "}\n"
                       for b in range(count))
    common = ("format: roadpreview beam calibration 1\nsensor_model: {model}\nserial: \"{serial}\"\n"
              "beam_count: {count}\nunits: {{angles: deg, ranges: m}}\nbeam_index: {index}\n")
    drive = "drive: {frames: 12, travel_m: 3.1, residual_m: 0.012}\nbeams:\n"
    decoder = common.format(model="OS-1-32", serial="122201000998", count=8, index="decoder") + drive + beams(8, False)
    elevation = (common.format(model="", serial="", count=12, index="elevation") +
                 "elevation_tilt_deg: [0.1, -0.04]\nindex_tolerance_deg: 0.2\n" + drive + beams(12, True))
    return {"decoder": decoder.encode(), "elevation": elevation.encode()}


def carmen_log():
    """A few lines of a CARMEN log (the shared recording is GPL-3.0 and stays out): PARAMs and FLASER scans."""
    lines = ["# CARMEN Logfile", "PARAM robot_front_laser_max 50.0 nohost 0",
             "PARAM laser_front_laser_resolution 1.0 nohost 0"]
    for k in range(3):
        ranges = " ".join(f"{4.0 + 0.01 * ((i * 7 + k) % 50):.2f}" for i in range(181))
        pose, stamp = f"{k * 0.1:.1f} 0.0 0.0", f"{100.0 + k / 37.5:.6f}"
        lines.append(f"FLASER 181 {ranges} {pose} {pose} {stamp} host {stamp}")
    return ("\n".join(lines) + "\n").encode()


def sick_seeds():
    """A small LMDscandata telegram in CoLa-B and CoLa-A framing (5 beams, DIST1 and RSSI1), a site and CSVs."""
    def channel(name, values, fmt):
        return name + struct.pack(">ffiHH", 1.0, 0.0, -450000, 5000, len(values)) + struct.pack(f">{len(values)}{fmt}", *values)
    body = (b"sSN LMDscandata " + struct.pack(">HHIBBHHIIBBBBHII", 1, 1, 18090362, 0, 0, 7, 4, 1000, 1200, 0, 0, 0, 0, 0,
                                              5000, 360)
            + struct.pack(">H", 0) + struct.pack(">H", 1) + channel(b"DIST1", [93, 80, 0, 1841, 62], "H")
            + struct.pack(">H", 1) + channel(b"RSSI1", [254, 0, 3, 4, 5], "B") + struct.pack(">HHHH", 0, 0, 0, 1)
            + struct.pack(">HBBBBBI", 1970, 1, 1, 2, 55, 34, 889000) + struct.pack(">H", 0))
    checksum = 0
    for b in body:
        checksum ^= b
    cola_b = b"\x02\x02\x02\x02" + struct.pack(">I", len(body)) + body + bytes([checksum])
    cola_a = (b"\x02sSN LMDscandata 1 1 1140A7A 0 0 7 4 3E8 4B0 0 0 0 0 0 1388 168 0 1 DIST1 3F800000 00000000 "
              b"FFF92230 1388 5 5D 50 0 731 3E 0 0 0 0 0\x03")
    site = (b"origin: {lat_deg: 49.0, lon_deg: 8.4, height_m: 110, heading_deg: 90}\n"
            b"scanners:\n  - {name: a, x_m: 0, y_m: 0, yaw_deg: 90, beams: 361, step_deg: 0.5}\n"
            b"camera:\n  points: [[0, 480, 0, 5], [720, 480, 5, 5], [720, 200, 5, 30], [0, 200, -5, 30]]\n"
            b"processing: {cell_m: 0.1, dilation_cells: 2, max_speed_mps: 3,\n"
            b"             world: {cell_m: 0.2, max_range_m: 30, min_free_scans: 10, max_hit_s: 4}}\n")
    return {"cola_b": b"\x00" + cola_b, "cola_a": b"\x00" + cola_a, "stream": b"\x01xx" + cola_b + cola_a + cola_b,
            "site": b"\x02" + site, "scan_csv": b"\x03t,scanner,angle_deg,range_m\n0,0,-90,5\n0,0,-89.5,\n",
            "detections": b"\x04t,x,y,w,h,class,score\n0.1,100,200,40,80,pedestrian,0.9\n",
            "carmen": b"\x05" + carmen_log(),
            "detections_jsonl": b"\x06" + b'{"t": 0.1, "x": 100, "y": 200, "w": 40, "h": 80, "class": "car", '
                                          b'"score": 0.9}\n'}


def png(width, height, colour_type, bit_depth, rows, extra=b""):
    """A PNG file: IHDR, optional chunks (PLTE, tRNS), one IDAT of the filter-0 rows, IEND."""
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))
    raw = b"".join(b"\x00" + row for row in rows)
    header = struct.pack(">IIBBBBB", width, height, bit_depth, colour_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + extra + chunk(b"IDAT", zlib.compress(raw))
            + chunk(b"IEND", b""))


def png_seeds():
    w, h = 16, 8
    grey = [bytes((3 * u + 7 * v) % 256 for u in range(w)) for v in range(h)]
    palette = b"".join(bytes((i, 255 - i, i // 2)) for i in range(16))
    return {
        "grey8": png(w, h, 0, 8, grey),
        "grey16": png(w, h, 0, 16, [b"".join(struct.pack(">H", 256 * b) for b in row) for row in grey]),
        "rgb8": png(w, h, 2, 8, [bytes(b for x in row for b in (x, 255 - x, x // 2)) for row in grey]),
        "rgba8": png(w, h, 6, 8, [bytes(b for x in row for b in (x, 255 - x, x // 2, 200)) for row in grey]),
        "grey_alpha": png(w, h, 4, 8, [bytes(b for x in row for b in (x, 90)) for row in grey]),
        "palette": png(w, h, 3, 4, [bytes((row[2 * i] % 16) << 4 | row[2 * i + 1] % 16 for i in range(w // 2))
                                    for row in grey], struct.pack(">I", 48) + b"PLTE" + palette
                       + struct.pack(">I", zlib.crc32(b"PLTE" + palette))),
        "grey1": png(w, h, 0, 1, [bytes((0b10110010 ^ v,)) * (w // 8) for v in range(h)]),
    }


def route_line_seeds():
    """Short output lines as the route and the readout read them back: profiles, an arc, a declined frame."""
    def line(frame, speed, path=None, reason=None, bins=12):
        profile = {"s": [round(0.1 * k + 0.05, 2) for k in range(bins)], "z": [0.01 * (k % 3) for k in range(bins)],
                   "count": [k % 4 for k in range(bins)], "spread": [0.002] * bins}
        return json.dumps({"frame": frame, "source": "a.bin", "timestamp": 0.1 * frame, "motion": {"speed": speed},
                           "path": path, "reason": reason, "profiles": {"left": profile, "right": profile}})
    arc = {"icr_y": 50.0, "left_radius": 49.2, "right_radius": 50.8}
    return {"straight": "\n".join(line(f, 10.0) for f in range(3)).encode(),
            "arc_and_declined": "\n".join([line(0, 5.0, arc), line(1, 5.0, reason="vehicle stopped"),
                                           line(2, -5.0, arc)]).encode()}


def main():
    data_dir, out_dir = Path(sys.argv[1]), Path(sys.argv[2])
    kitti = (data_dir / "semantickitti/000000.bin").read_bytes()
    calibration = "distance_resolution: 0.002\nnum_lasers: 4\nlasers:\n" + "".join(
        f"- {{laser_id: {i}, rot_correction: 0.01, vert_correction: {-0.1 * i}, dist_correction: 0.5, "
        "vert_offset_correction: 0.1, horiz_offset_correction: 0.0}\n" for i in range(4))
    config = {"sensor_height": 1.73, "track_width": 1.6, "ground": {"method": "pca", "roi_x_max_m": 40.0},
              "profile": {"ds_m": 0.1}, "fusion": {"method": "kalman"}}
    seeds = {
        "packet_decoders": dict(packet_decoder_seeds(data_dir)),
        "pcap": dict(pcap_seeds(data_dir)),
        "ouster_metadata": {p.stem: p.read_bytes() for p in sorted((data_dir / "ouster").glob("*.json"))},
        "velodyne_calibration": {"four_lasers": calibration.encode()},
        "pcd": dict(pcd_seeds(data_dir)),
        "ply": dict(ply_seeds(data_dir)),
        "beams": beams_seeds(),
        "stereo_calibration": {"kitti": b"\x00" + (data_dir / "stereo/kitti_object_calib.txt").read_bytes(),
                               "yaml": b"\x01fx: 721.5\nfy: 721.5\ncx: 609.6\ncy: 172.9\nbaseline: 0.54\n"
                                       b"extrinsics: {x_m: 0.27, y_m: 0.06, z_m: 1.65, roll_rad: 0, pitch_rad: 0.01, "
                                       b"yaw_rad: 0}\n"},
        "stereo_images": png_seeds(),
        "kitti_bin": {"first_rows": kitti[: 256 * 16]},
        "config": {"json": b"\x00" + json.dumps(config).encode(),
                   "yaml": b"\x01sensor_height: 1.73\nground:\n  method: ransac\nprofile:\n  ds_m: 0.1\n"},
        "csv": {"motion": b"\x00t,speed,yaw_rate\n# comment\n0,5,0.1\n0.5,5.5,0.05\n1,6,0\n",
                "poses": b"\x01" + b"".join((data_dir / "ouster/OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt")
                                            .read_bytes().splitlines(keepends=True)[:3])},
        "sick_telegram": sick_seeds(),
        "route_lines": route_line_seeds(),
        "range_sensor": {
            "layout": b"\x00sensors:\n  - {id: a, kind: ultrasonic, wheel: left, x_m: 0.5, y_m: 0.8, height_m: 0.3, "
                      b"pitch_deg: 0, beam_half_angle_deg: 12, min_count: 100, max_count: 4000}\n"
                      b"  - {id: b, kind: laser, wheel: right, x_m: 0.5, y_m: -0.8, height_m: 0.3}\n",
            "calibration": b"\x01distance: {a1: 0.001, a2: 0.002, temperature_c: 20}\n"
                           b"sensors:\n  a: {offset: {b1: 0.01, b2: 0.4}}\n",
            "counts": b"\x02t,sensor,count,temperature_c\n# comment\n"
                      + b"".join(b"%.3f,%s,%d,20\n" % (0.01 * i, b"lr"[i % 2:i % 2 + 1], 300 + i % 7) for i in range(80)),
            "distances": b"\x05sensor,t,distance\n" + b"".join(b"r,%.3f,%.4f\n" % (0.01 * i, 0.3 + 0.001 * (i % 5))
                                                                 for i in range(80))},
    }
    for target, files in seeds.items():
        folder = out_dir / target
        folder.mkdir(parents=True, exist_ok=True)
        for name, data in files.items():
            (folder / f"seed_{name}").write_bytes(data[:MAX_SEED_BYTES + 1])
        print(f"{target}: {len(files)} seeds", file=sys.stderr)


if __name__ == "__main__":
    main()
