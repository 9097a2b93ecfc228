// The 1-minute load average (/proc/loadavg), printed beside the benchmarks' timings: this machine is shared,
// and a loaded one gives outliers that a median of a few rounds does not remove.
#pragma once
#include <cstdio>
#include <cstring>
#include <string>

inline std::string load_average() {
  std::string load = "?";
  if (std::FILE* f = std::fopen("/proc/loadavg", "r")) {
    char buf[64] = {};
    if (std::fgets(buf, sizeof buf, f)) load = std::string(buf, std::strcspn(buf, " "));
    std::fclose(f);
  }
  return load;
}
