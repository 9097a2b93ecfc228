// Keeps grains_output non-empty before its writers exist.
namespace grains { int output_library_anchor = 0; }
