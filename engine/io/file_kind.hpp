// What a path names when it is not a regular file: grains reads and writes regular files only. Read as HDF5, a FIFO
// blocks until something writes into it, and a folder or a device fails inside HDF5 with a message about signatures;
// written over, such a name was replaced or was found unwritable only once the run had begun. One check for every
// file grains opens by name (a resume's file, the outputs), so that each says the same.
#pragma once
#include <filesystem>
#include <optional>
#include <string>
#include <system_error>

namespace grains {

// What `path` names, its links followed, when that is not a regular file: "a folder", "a FIFO (named pipe)", "a
// character device", "a block device", "a socket" or "something other than a file". Nothing for a regular file, for a
// name that holds nothing (an output may be made there), and where the system cannot tell (a folder on the way that
// cannot be read, a loop of links): opening the file then says why.
inline std::optional<std::string> not_a_regular_file(const std::string& path) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec) return std::nullopt;
  switch (status.type()) {
    case fs::file_type::regular:
    case fs::file_type::not_found:
    case fs::file_type::none:
      return std::nullopt;
    case fs::file_type::directory: return "a folder";
    case fs::file_type::fifo: return "a FIFO (named pipe)";
    case fs::file_type::character: return "a character device";
    case fs::file_type::block: return "a block device";
    case fs::file_type::socket: return "a socket";
    default: return "something other than a file";
  }
}

}  // namespace grains
