// The two checkpoint slots of a run's file (h5md_checkpoint.hpp), shared by the writer and the reader.
// Internal to grains_output.
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "io/h5md_hdf5.hpp"

namespace grains {

inline const char* checkpoint_slot_name(int slot) { return slot == 0 ? "checkpoint_0" : "checkpoint_1"; }

// (slot, step) of the slots marked valid in the /grains group `grains`, newest first.
inline std::vector<std::pair<int, double>> valid_checkpoint_slots(hid_t grains, const std::string& file) {
  std::vector<std::pair<int, double>> slots;
  for (int k : {0, 1}) {
    if (!h5::exists(grains, checkpoint_slot_name(k), file)) continue;
    const h5::Handle d = h5::open_dataset(grains, checkpoint_slot_name(k), file);
    if (h5::read_attr_double(d.get(), "valid", 0, file) == 1)
      slots.emplace_back(k, h5::read_attr_double(d.get(), "step", -1, file));
  }
  if (slots.size() == 2 && slots[1].second > slots[0].second) std::swap(slots[0], slots[1]);
  return slots;
}

}  // namespace grains
