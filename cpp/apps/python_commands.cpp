// SPDX-License-Identifier: BSD-3-Clause
#include "python_commands.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include "helper_programs.hpp"

namespace {

constexpr const char* kPythonCli = "roadpreview-drives";

bool is_bag(const std::string& arg) {
    namespace fs = std::filesystem;
    for (const std::string suffix : {".bag", ".mcap", ".db3"})
        if (arg.size() > suffix.size() && arg.compare(arg.size() - suffix.size(), std::string::npos, suffix) == 0)
            return true;
    std::error_code ec;
    return fs::is_directory(arg, ec) && fs::is_regular_file(fs::path(arg) / "metadata.yaml", ec);
}

bool wants_python(int argc, char** argv) {
    if (argc < 2) return false;
    const std::string command = argv[1];
    if (command == "batch") return true;
    if (command != "run" && command != "info") return false;
    for (int i = 2; i < argc; ++i) {
        const std::string arg = argv[i];
        if (arg == "--topic" || arg.rfind("--topic=", 0) == 0 || arg == "--motion-from" ||
            arg.rfind("--motion-from=", 0) == 0 || is_bag(arg))
            return true;
    }
    return false;
}

}  // namespace

std::optional<int> delegate_to_python(int argc, char** argv) {
    if (!wants_python(argc, argv)) return std::nullopt;
    const std::string program = program_beside_self(kPythonCli);
    std::vector<char*> args{const_cast<char*>(program.c_str())};
    for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
    args.push_back(nullptr);
    execvp(program.c_str(), args.data());
    std::fprintf(stderr,
                 "roadpreview: error: `%s` is handled by the Python package's %s, which could not be started (%s); "
                 "install it with pip install 'roadpreview[drives]'\n",
                 argv[1], kPythonCli, std::strerror(errno));
    return 2;
}
