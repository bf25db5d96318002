"""Rewriting bundled recordings into the variants the reader must handle (dpkt builds the packets)."""

from __future__ import annotations

from pathlib import Path

import dpkt


def records(path: Path) -> list[tuple[float, bytes]]:
    with open(path, "rb") as f:
        return [(ts, bytes(buf)) for ts, buf in dpkt.pcap.Reader(f)]


def write_pcap(path: Path, recs, linktype: int = dpkt.pcap.DLT_EN10MB) -> Path:
    with open(path, "wb") as f:
        w = dpkt.pcap.Writer(f, snaplen=65535, linktype=linktype, nano=False)
        for ts, buf in recs:
            w.writepkt(buf, ts=ts)
    return path


def write_pcapng(path: Path, recs, linktype: int = dpkt.pcap.DLT_EN10MB) -> Path:
    with open(path, "wb") as f:
        w = dpkt.pcapng.Writer(f, snaplen=65535, linktype=linktype)
        for ts, buf in recs:
            w.writepkt(buf, ts=ts)
    return path


def udp_of(buf: bytes):
    """(Ethernet, IP, UDP) of an Ethernet record, or None."""
    eth = dpkt.ethernet.Ethernet(buf)
    ip = eth.data
    if not isinstance(ip, dpkt.ip.IP) or not isinstance(ip.data, dpkt.udp.UDP):
        return None
    return eth, ip, ip.data


def fragment(buf: bytes, mtu: int = 1500, reverse: bool = False) -> list[bytes]:
    """An Ethernet/IPv4 record split into IP fragments of at most `mtu` bytes of IP packet, as a 1500-byte
    MTU link would carry a jumbo lidar datagram."""
    eth, ip, _ = udp_of(buf)
    payload = bytes(ip.data)  # UDP header + data
    step = (mtu - 20) // 8 * 8
    frags = []
    for off in range(0, len(payload), step):
        piece = payload[off:off + step]
        more = off + step < len(payload)
        f = dpkt.ip.IP(src=ip.src, dst=ip.dst, id=ip.id or 4242, ttl=ip.ttl, p=ip.p, data=piece)
        f.mf, f.offset = int(more), off // 8  # the offset field counts 8-byte units
        f.len = 20 + len(piece)
        frags.append(bytes(dpkt.ethernet.Ethernet(src=eth.src, dst=eth.dst, type=eth.type, data=f)))
    return frags[::-1] if reverse else frags


def linux_cooked(buf: bytes) -> bytes:
    """The record's IP packet behind a Linux cooked-capture (SLL) header instead of Ethernet."""
    eth = dpkt.ethernet.Ethernet(buf)
    sll = dpkt.sll.SLL(type=0, hrd=1, hlen=6, hdr=eth.src + b"\0\0", ethtype=eth.type, data=eth.data)
    return bytes(sll)
