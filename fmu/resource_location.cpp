#include "resource_location.hpp"

#include <dlfcn.h>

#include <stdexcept>

namespace grains::fmu {

std::filesystem::path decode_resource_location(const std::string& location) {
  std::string path = location;
  if (path.rfind("file:", 0) == 0) {
    path = path.substr(5);
    if (path.rfind("//", 0) == 0) {   // an authority: empty or localhost
      const auto slash = path.find('/', 2);
      const std::string host = path.substr(2, slash == std::string::npos ? std::string::npos : slash - 2);
      if (!host.empty() && host != "localhost")
        throw std::invalid_argument("resource location '" + location + "' names a remote host; a local file URI is needed");
      path = slash == std::string::npos ? "/" : path.substr(slash);
    }
  } else if (path.find("://") != std::string::npos) {
    throw std::invalid_argument("resource location '" + location + "' is not a file URI or a path");
  } else {
    return std::filesystem::path(path);   // a plain path (FMI 3): taken literally, '%' included
  }
  std::string decoded;
  for (std::size_t i = 0; i < path.size(); ++i) {
    auto hex = [&](char c) -> int {
      if (c >= '0' && c <= '9') return c - '0';
      if (c >= 'a' && c <= 'f') return c - 'a' + 10;
      if (c >= 'A' && c <= 'F') return c - 'A' + 10;
      return -1;
    };
    if (path[i] == '%' && i + 2 < path.size() && hex(path[i + 1]) >= 0 && hex(path[i + 2]) >= 0) {
      decoded += char(hex(path[i + 1]) * 16 + hex(path[i + 2]));
      i += 2;
    } else {
      decoded += path[i];
    }
  }
  return std::filesystem::path(decoded);
}

std::filesystem::path binary_directory() {
  Dl_info info{};
  if (dladdr(reinterpret_cast<void*>(&binary_directory), &info) == 0 || !info.dli_fname) return {};
  return std::filesystem::absolute(info.dli_fname).parent_path();
}

std::filesystem::path resources_beside_binary() {
  const std::filesystem::path binaries = binary_directory();   // <fmu>/binaries/<platform>
  if (binaries.empty()) return {};
  return binaries.parent_path().parent_path() / "resources";
}

}  // namespace grains::fmu
