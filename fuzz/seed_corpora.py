#!/usr/bin/env python3
# SPDX-License-Identifier: BSD-3-Clause
"""Writes a seed corpus per fuzz target from the real files in tests/data (stdlib only).

Usage: seed_corpora.py TESTS_DATA_DIR OUT_DIR  → OUT_DIR/<target>/seed_*. Seeds are kept small (a few kB to
64 kB) so libFuzzer spends its time mutating structure, not copying megabytes.
"""
import json
import struct
import sys
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


def pcap_seeds(data_dir):
    yield "ouster_os1_32", b"\x01" + leading_records(data_dir / "ouster/OS-1-32-G_v2.1.1_1024x10.pcap")
    for name in ("velodyne_example", "hdl32_example", "velodyne_vlp16"):
        yield name, b"\x00" + leading_records(data_dir / f"velodyne/{name}.pcap")


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


def pcd_seeds(data_dir):
    kitti = (data_dir / "semantickitti/000000.bin").read_bytes()[: 64 * 16]
    rows = [struct.unpack_from("<4f", kitti, 16 * i) for i in range(64)]
    fields = ["x", "y", "z", "intensity"]
    yield "ascii", pcd_text(fields, 64, "ascii") + "".join(" ".join(f"{v:.4f}" for v in r) + "\n" for r in rows).encode()
    yield "binary", pcd_text(fields, 64, "binary") + kitti
    soa = b"".join(struct.pack(f"<{len(rows)}f", *[r[k] for r in rows]) for k in range(4))  # field by field
    packed = lzf_literals(soa)
    yield "binary_compressed", pcd_text(fields, 64, "binary_compressed") + struct.pack("<II", len(packed), len(soa)) + packed
    real = (data_dir / "pcd/patchwork_128ring_000000.pcd").read_bytes()
    yield "real_head", real[:4096]


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
            b"processing: {cell_m: 0.1, dilation_cells: 2}\n")
    return {"cola_b": b"\x00" + cola_b, "cola_a": b"\x00" + cola_a, "stream": b"\x01xx" + cola_b + cola_a + cola_b,
            "site": b"\x02" + site, "scan_csv": b"\x03t,scanner,angle_deg,range_m\n0,0,-90,5\n0,0,-89.5,\n",
            "detections": b"\x04t,x,y,w,h,class,score\n0.1,100,200,40,80,pedestrian,0.9\n"}


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
        "kitti_bin": {"first_rows": kitti[: 256 * 16]},
        "config": {"json": b"\x00" + json.dumps(config).encode(),
                   "yaml": b"\x01sensor_height: 1.73\nground:\n  method: ransac\nprofile:\n  ds_m: 0.1\n"},
        "csv": {"motion": b"\x00t,speed,yaw_rate\n# comment\n0,5,0.1\n0.5,5.5,0.05\n1,6,0\n",
                "poses": b"\x01" + b"".join((data_dir / "ouster/OS-1-128_v2.3.0_1024x10_lb_n3_poses_kitti.txt")
                                            .read_bytes().splitlines(keepends=True)[:3])},
        "sick_telegram": sick_seeds(),
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
