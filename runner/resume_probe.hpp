// Before `grains resume` opens a file, a child process reads what the resume will read (io/h5md_resume_reads.hpp):
// HDF5 1.10.8 takes some damaged headers as they read and dies inside its own decoding (SIGFPE at a chunk dimension
// made 0 in H5Dopen2, SIGSEGV or a fortified abort at an XDMF view's damaged mapping), before any check of grains'
// could see them. The child dies in the resume's place, and the resume refuses the file.
#pragma once
#include <chrono>
#include <string>

namespace grains {

// The longest the child may spend on one object of the file: a damaged header can make HDF5 loop without end.
// Each takes well under a millisecond (a checkpoint's bytes, a few): a file of 1001 frames (200 MB) resumed from its
// middle is read in about 0.14 s. A limit on the whole reading would refuse a long enough run's file.
inline constexpr std::chrono::seconds kObjectLimit{60};

// Throws std::runtime_error naming `path`, and the object the child was reading, when the child died by a signal, ended
// otherwise than as it ends after reading, or spent longer than `object_limit` on one object. HDF5's errors are the resume's to
// report: the child passes over them. `path` must be a regular file (not_a_regular_file, io/file_kind.hpp): a FIFO
// holds the child until its time is up. Call it before anything starts OpenMP's threads (a fork copies only the
// calling thread). `object_limit`: kObjectLimit, shorter in the tests.
void refuse_a_file_hdf5_dies_reading(const std::string& path, std::chrono::seconds object_limit = kObjectLimit);

}  // namespace grains
