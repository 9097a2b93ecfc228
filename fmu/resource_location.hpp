// Where the FMU's resources/ directory is: from the URI (FMI 2) or path (FMI 3) the host passes,
// percent-decoded, or else found next to this shared library (binaries/<platform>/ -> resources/); and where this
// shared library itself is.
#pragma once
#include <filesystem>
#include <string>

namespace grains::fmu {

// "file:///a/b%20c/resources" (also file:/..., file://localhost/...) -> /a/b c/resources (URIs are
// percent-decoded); a plain path is taken as it is.
// Throws std::invalid_argument naming the location when it is not a local file URI or path.
std::filesystem::path decode_resource_location(const std::string& location);

// The folder of this binary, binaries/<platform>/ of the extracted FMU (empty if the loader cannot say), where the
// libraries shipped beside it are.
std::filesystem::path binary_directory();

// resources/ of the extracted FMU that contains this binary.
std::filesystem::path resources_beside_binary();

}  // namespace grains::fmu
