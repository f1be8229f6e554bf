#include "io/pressure_field_writer.h"

#include <filesystem>
#include <fmt/format.h>

#include "core/errors.h"
#include "pressure/learned_warm_start.h"

namespace iqmpm {
namespace {

void string_attribute(hid_t object, const char* name, const std::string& value) {
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  H5Tset_cset(type, H5T_CSET_UTF8);
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t attribute = H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  const char* text = value.c_str();
  H5Awrite(attribute, type, &text);
  H5Aclose(attribute);
  H5Sclose(space);
  H5Tclose(type);
}

template <class T>
void array_attribute(hid_t object, const char* name, hid_t type, const std::vector<T>& values, bool scalar = false) {
  const hsize_t size = values.size();
  hid_t space = scalar ? H5Screate(H5S_SCALAR) : H5Screate_simple(1, &size, nullptr);
  hid_t attribute = H5Acreate2(object, name, type, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attribute, type, values.data());
  H5Aclose(attribute);
  H5Sclose(space);
}

// A dataset of shape [0, frame...] that grows along its first axis, one chunk per step.
hid_t growing_dataset(hid_t file, const char* name, hid_t type, const std::vector<hsize_t>& frame, bool compressed) {
  std::vector<hsize_t> dims{0}, max{H5S_UNLIMITED}, chunk{1};
  for (hsize_t n : frame) {
    dims.push_back(n);
    max.push_back(n);
    chunk.push_back(n);
  }
  if (!compressed) chunk[0] = 1024;  // the per-step scalars
  hid_t space = H5Screate_simple(int(dims.size()), dims.data(), max.data());
  hid_t properties = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_chunk(properties, int(chunk.size()), chunk.data());
  if (compressed) H5Pset_deflate(properties, 4);
  hid_t set = H5Dcreate2(file, name, type, space, H5P_DEFAULT, properties, H5P_DEFAULT);
  H5Pclose(properties);
  H5Sclose(space);
  return set;
}

void append_row(hid_t set, hid_t type, hsize_t row, const std::vector<hsize_t>& frame, const void* data) {
  std::vector<hsize_t> dims{row + 1}, start{row}, count{1};
  for (hsize_t n : frame) {
    dims.push_back(n);
    start.push_back(0);
    count.push_back(n);
  }
  H5Dset_extent(set, dims.data());
  hid_t file_space = H5Dget_space(set);
  H5Sselect_hyperslab(file_space, H5S_SELECT_SET, start.data(), nullptr, count.data(), nullptr);
  hid_t memory_space = H5Screate_simple(int(count.size()), count.data(), nullptr);
  const herr_t status = H5Dwrite(set, type, memory_space, file_space, H5P_DEFAULT, data);
  H5Sclose(memory_space);
  H5Sclose(file_space);
  if (status < 0) throw NumericalFailure("cannot write pressure_fields.h5 (disk full?)");
}

}  // namespace

PressureFieldWriter::PressureFieldWriter(const std::string& directory, const std::string& scene_name, Real dx,
                                         const std::vector<Real>& origin, const std::vector<int>& cells)
    : path_((std::filesystem::path(directory) / "pressure_fields.h5").string()) {
  frame_shape_.push_back(LearnedPredictor::fields.size());
  for (int n : cells) frame_shape_.push_back(hsize_t(n));
  file_ = H5Fcreate((path_ + ".part").c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file_ < 0) throw InputError(fmt::format("cannot write '{}.part'", path_));
  string_attribute(file_, "format", "iqmpm-pressure-fields");
  array_attribute(file_, "format_version", H5T_NATIVE_INT, std::vector<int>{1}, true);
  array_attribute(file_, "dim", H5T_NATIVE_INT, std::vector<int>{int(cells.size())}, true);
  array_attribute(file_, "dx", H5T_NATIVE_DOUBLE, std::vector<double>{dx}, true);
  array_attribute(file_, "origin", H5T_NATIVE_DOUBLE, origin);
  array_attribute(file_, "cells", H5T_NATIVE_INT, cells);
  string_attribute(file_, "scene_name", scene_name);
  string_attribute(file_, "fields", "fluid_pressure,ghost_pressure,interface");
  string_attribute(file_, "units", "Pa");
  string_attribute(file_, "layout",
                   "fields[step, field, i, j(, k)]: dual cell (i, j, k) centred at origin + dx (i + 1/2, j + 1/2, k + 1/2); "
                   "0 where active is 0");
  fields_ = growing_dataset(file_, "fields", H5T_NATIVE_FLOAT, frame_shape_, true);
  active_ = growing_dataset(file_, "active", H5T_NATIVE_UCHAR, frame_shape_, true);
  time_ = growing_dataset(file_, "time", H5T_NATIVE_DOUBLE, {}, false);
  dt_ = growing_dataset(file_, "dt", H5T_NATIVE_DOUBLE, {}, false);
  step_ = growing_dataset(file_, "step", H5T_NATIVE_LLONG, {}, false);
  iterations_ = growing_dataset(file_, "iterations", H5T_NATIVE_INT, {}, false);
}

PressureFieldWriter::~PressureFieldWriter() {
  try {
    close();
  } catch (...) {
  }
}

void PressureFieldWriter::append(const GridSolution& solution, double dt, long step, int iterations) {
  std::size_t count = 1;
  for (std::size_t a = 1; a < frame_shape_.size(); ++a) count *= frame_shape_[a];
  values_.assign(LearnedPredictor::fields.size() * count, 0);
  masks_.assign(values_.size(), 0);
  for (std::size_t c = 0; c < LearnedPredictor::fields.size(); ++c) {
    const auto& value = solution.value[LearnedPredictor::fields[c]];
    const auto& active = solution.active[LearnedPredictor::fields[c]];
    if (value.size() != count) continue;
    for (std::size_t k = 0; k < count; ++k) {
      values_[c * count + k] = mpmnet_value(value[k]);
      masks_[c * count + k] = active[k];
    }
  }
  append_row(fields_, H5T_NATIVE_FLOAT, steps_, frame_shape_, values_.data());
  append_row(active_, H5T_NATIVE_UCHAR, steps_, frame_shape_, masks_.data());
  append_row(time_, H5T_NATIVE_DOUBLE, steps_, {}, &solution.time);
  append_row(dt_, H5T_NATIVE_DOUBLE, steps_, {}, &dt);
  const long long number = step;
  append_row(step_, H5T_NATIVE_LLONG, steps_, {}, &number);
  append_row(iterations_, H5T_NATIVE_INT, steps_, {}, &iterations);
  ++steps_;
}

void PressureFieldWriter::close() {
  if (file_ < 0) return;
  for (hid_t set : {fields_, active_, time_, dt_, step_, iterations_}) H5Dclose(set);
  H5Fclose(file_);
  file_ = -1;
  std::filesystem::rename(path_ + ".part", path_);
}

}  // namespace iqmpm
