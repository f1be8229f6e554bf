// A run's state at a step boundary (checkpoint.h5; docs/method.md#checkpoints): named flat
// arrays of doubles, integers and bytes plus a JSON record of the small values, written to
// one HDF5 file through a temporary name and a rename, and read back bit for bit. HDF5
// keeps it readable by any tool (h5dump, h5py) and portable across machines.
#pragma once

#include <cstdint>
#include <map>
#include <fmt/format.h>

#include <string>
#include <vector>

#include "core/errors.h"
#include "scene/json_reader.h"

namespace iqmpm {

class StateArchive {
 public:
  Json record;  // small values: times, counters, the scene; doubles round-trip exactly

  void put(const std::string& name, std::vector<double> values) { doubles_[name] = std::move(values); }
  void put(const std::string& name, std::vector<std::int64_t> values) { integers_[name] = std::move(values); }
  void put(const std::string& name, std::vector<std::uint8_t> values) { bytes_[name] = std::move(values); }

  // The array `name`; InputError naming the file and the array when it is missing.
  const std::vector<double>& doubles(const std::string& name) const { return find(doubles_, name); }
  const std::vector<std::int64_t>& integers(const std::string& name) const { return find(integers_, name); }
  const std::vector<std::uint8_t>& bytes(const std::string& name) const { return find(bytes_, name); }

  bool contains(const std::string& name) const {
    return doubles_.count(name) > 0 || integers_.count(name) > 0 || bytes_.count(name) > 0;
  }

  // Atomic: `path`.tmp, then renamed to `path`.
  void write(const std::string& path) const;
  // InputError naming the file when it is missing, not HDF5, or not a checkpoint.
  static StateArchive read(const std::string& path);

 private:
  template <class T>
  const std::vector<T>& find(const std::map<std::string, std::vector<T>>& arrays, const std::string& name) const {
    const auto it = arrays.find(name);
    if (it == arrays.end())
      throw InputError(fmt::format("checkpoint '{}' has no array '{}' (written by another version of iqmpm?)", source_, name));
    return it->second;
  }

  std::string source_;  // the file it was read from (for messages)
  std::map<std::string, std::vector<double>> doubles_;
  std::map<std::string, std::vector<std::int64_t>> integers_;
  std::map<std::string, std::vector<std::uint8_t>> bytes_;
};

// Flat copies of arrays of fixed-size Eigen vectors or matrices (Vec<dim>, Mat<dim>), which
// are stored without padding, and back.
template <class Fixed>
std::vector<double> flatten(const std::vector<Fixed>& values) {
  static_assert(sizeof(Fixed) == Fixed::SizeAtCompileTime * sizeof(double));
  const double* first = values.empty() ? nullptr : values.front().data();
  return std::vector<double>(first, first + values.size() * Fixed::SizeAtCompileTime);
}
template <class Fixed>
std::vector<Fixed> unflatten(const std::vector<double>& flat) {
  std::vector<Fixed> values(flat.size() / Fixed::SizeAtCompileTime);
  for (std::size_t i = 0; i < values.size(); ++i)
    for (int k = 0; k < Fixed::SizeAtCompileTime; ++k) values[i].data()[k] = flat[i * Fixed::SizeAtCompileTime + k];
  return values;
}

}  // namespace iqmpm
