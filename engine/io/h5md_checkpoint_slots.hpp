// The two checkpoint slots of a run's file (h5md_checkpoint.hpp), shared by the writer and the reader.
// Internal to grains_output.
#pragma once
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "io/h5md_hdf5.hpp"

namespace grains {

inline const char* checkpoint_slot_name(int slot) { return slot == 0 ? "checkpoint_0" : "checkpoint_1"; }

// A slot as the writer makes it: one axis of bytes, in chunks of 64 KiB, each with a Fletcher-32 checksum.
constexpr hsize_t kCheckpointChunkBytes = 1 << 16;
inline h5::Handle create_checkpoint_slot(hid_t grains, int slot, const std::string& file) {
  return h5::create_extendable(grains, checkpoint_slot_name(slot), H5T_STD_U8LE, {}, {}, kCheckpointChunkBytes, file, true);
}
// Refuses a slot of a resumed file that is not laid out as create_checkpoint_slot makes it: the resumed run writes its
// checkpoints over the slots (H5Dset_extent, H5Dwrite), and with chunks of 65,536 bytes made 67,174,400 in the layout
// by one flipped bit, HDF5 1.10.8's Fletcher-32 in H5Dwrite summed that many and crashed.
inline void check_checkpoint_slot(hid_t grains, int slot, const std::string& file) {
  const h5::Handle d = h5::open_dataset(grains, checkpoint_slot_name(slot), file);
  h5::check_as_written(d.get(), H5T_STD_U8LE, kCheckpointChunkBytes, file, std::string("/grains/") + checkpoint_slot_name(slot),
                       true);
}

// (slot, step) of the slots marked valid in the /grains group `grains`, newest first. A slot whose 'valid' or 'step'
// does not read as grains writes it is left out, like an invalid one, and added to `damaged` (when given) with what is
// wrong with it: the other slot may be whole.
inline std::vector<std::pair<int, double>> valid_checkpoint_slots(hid_t grains, const std::string& file,
                                                                  std::vector<std::pair<int, std::string>>* damaged = nullptr) {
  std::vector<std::pair<int, double>> slots;
  for (int k : {0, 1}) {
    if (!h5::exists(grains, checkpoint_slot_name(k), file)) continue;
    try {
      const h5::Handle d = h5::open_dataset(grains, checkpoint_slot_name(k), file);
      // Steps below Simulation::max_steps (1e15), exact as doubles; any other is no step a run wrote.
      if (h5::read_attr_in(d.get(), "valid", 0, 0, 1, true, file) == 1)
        slots.emplace_back(k, h5::read_attr_in(d.get(), "step", -1, 0, 1e15, true, file));
    } catch (const std::runtime_error& e) {
      if (damaged) damaged->emplace_back(k, h5::defect_of(e));
    }
  }
  if (slots.size() == 2 && slots[1].second > slots[0].second) std::swap(slots[0], slots[1]);
  return slots;
}

}  // namespace grains
