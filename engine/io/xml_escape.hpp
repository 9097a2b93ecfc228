// Text made safe for an XML attribute or element (the XDMF companion, FMI model descriptions).
#pragma once
#include <string>
#include <string_view>

namespace grains {

inline std::string xml_escape(std::string_view text) {
  std::string out;
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

}  // namespace grains
