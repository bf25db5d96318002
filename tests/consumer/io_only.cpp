// Uses the installed recording I/O alone, calling nothing of the core itself: the linker then drops the core from
// the program's own needs (--as-needed), and roadpreview_io must find it on its own when the program starts.
#include <cstdio>

#include <roadpreview/roadpreview.hpp>

int main() {
    const bool pcap = roadpreview::is_pcap_path("drive.pcap");
    std::printf("drive.pcap is %s\n", pcap ? "a capture" : "not a capture");
    return pcap ? 0 : 1;
}
