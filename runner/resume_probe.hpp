// Before `grains resume` opens a file, a child process reads what the resume will read (io/h5md_resume_reads.hpp):
// HDF5 1.10.8 takes some damaged headers as they read and dies inside its own decoding (SIGFPE at a chunk dimension
// made 0 in H5Dopen2, SIGSEGV or a fortified abort at an XDMF view's damaged mapping), before any check of grains'
// could see them. The child dies in the resume's place, and the resume refuses the file.
#pragma once
#include <string>

namespace grains {

// Throws std::runtime_error naming `path` when the child reading it died by a signal, ended otherwise than as it
// ends after reading, or spent more than a minute on one object. HDF5's errors are the resume's to report: the child
// passes over them. Call it before anything starts OpenMP's threads (a fork copies only the calling thread).
void refuse_a_file_hdf5_dies_reading(const std::string& path);

}  // namespace grains
