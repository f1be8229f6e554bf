#include "io/state_archive.h"

#include <hdf5.h>

#include <filesystem>
#include <fmt/format.h>

#include "core/errors.h"

namespace iqmpm {
namespace {

// One group per element type; each array is a 1-D dataset named by its key.
constexpr const char* kDoubles = "/double";
constexpr const char* kIntegers = "/int64";
constexpr const char* kBytes = "/uint8";
constexpr const char* kRecord = "/record";  // the JSON record's text, as bytes

template <class T>
void write_group(hid_t file, const char* group_name, hid_t type, const std::map<std::string, std::vector<T>>& arrays,
                 const std::string& path) {
  const hid_t group = H5Gcreate2(file, group_name, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  for (const auto& [name, values] : arrays) {
    const hsize_t size = values.size();
    const hid_t space = H5Screate_simple(1, &size, nullptr);
    const hid_t set = H5Dcreate2(group, name.c_str(), type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    const herr_t status = set < 0 ? -1 : size ? H5Dwrite(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) : 0;
    if (set >= 0) H5Dclose(set);
    H5Sclose(space);
    if (status < 0) {
      H5Gclose(group);
      throw InputError(fmt::format("cannot write '{}' (array '{}'; disk full?)", path, name));
    }
  }
  H5Gclose(group);
}

template <class T>
void read_group(hid_t file, const char* group_name, hid_t type, std::map<std::string, std::vector<T>>& arrays,
                const std::string& path) {
  const hid_t group = H5Gopen2(file, group_name, H5P_DEFAULT);
  if (group < 0) throw InputError(fmt::format("'{}' is not a checkpoint of iqmpm (no group '{}')", path, group_name));
  hsize_t count = 0;
  H5Gget_num_objs(group, &count);
  for (hsize_t i = 0; i < count; ++i) {
    const ssize_t length = H5Gget_objname_by_idx(group, i, nullptr, 0);
    std::string name(std::size_t(length), '\0');
    H5Gget_objname_by_idx(group, i, name.data(), std::size_t(length) + 1);
    const hid_t set = H5Dopen2(group, name.c_str(), H5P_DEFAULT);
    const hid_t space = H5Dget_space(set);
    const hssize_t size = H5Sget_simple_extent_npoints(space);
    std::vector<T> values(std::size_t(std::max<hssize_t>(size, 0)));
    const herr_t status = values.empty() ? 0 : H5Dread(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data());
    H5Sclose(space);
    H5Dclose(set);
    if (status < 0) {
      H5Gclose(group);
      throw InputError(fmt::format("'{}': cannot read array '{}' (a damaged checkpoint?)", path, name));
    }
    arrays[name] = std::move(values);
  }
  H5Gclose(group);
}

}  // namespace

void StateArchive::write(const std::string& path) const {
  const std::string temporary = path + ".tmp";
  const hid_t file = H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file < 0) throw InputError(fmt::format("cannot write '{}'", path));
  try {
    write_group(file, kDoubles, H5T_NATIVE_DOUBLE, doubles_, path);
    write_group(file, kIntegers, H5T_NATIVE_INT64, integers_, path);
    write_group(file, kBytes, H5T_NATIVE_UINT8, bytes_, path);
    const std::string text = record.dump();
    std::map<std::string, std::vector<std::uint8_t>> record_bytes{{"json", std::vector<std::uint8_t>(text.begin(), text.end())}};
    write_group(file, kRecord, H5T_NATIVE_UINT8, record_bytes, path);
  } catch (...) {
    H5Fclose(file);
    std::filesystem::remove(temporary);
    throw;
  }
  if (H5Fclose(file) < 0) throw InputError(fmt::format("cannot write '{}' (disk full?)", path));
  std::filesystem::rename(temporary, path);
}

StateArchive StateArchive::read(const std::string& path) {
  if (!std::filesystem::is_regular_file(path))
    throw InputError(fmt::format("no checkpoint '{}' (a run writes one every checkpoint.every_frames frames, on "
                                 "SIGINT / SIGTERM and at its end)", path));
  H5E_auto2_t handler;
  void* data;
  H5Eget_auto2(H5E_DEFAULT, &handler, &data);
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);  // our messages, not HDF5's stack dumps
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  StateArchive archive;
  archive.source_ = path;
  try {
    if (file < 0) throw InputError(fmt::format("'{}' is not an HDF5 file (a damaged checkpoint?)", path));
    read_group(file, kDoubles, H5T_NATIVE_DOUBLE, archive.doubles_, path);
    read_group(file, kIntegers, H5T_NATIVE_INT64, archive.integers_, path);
    read_group(file, kBytes, H5T_NATIVE_UINT8, archive.bytes_, path);
    std::map<std::string, std::vector<std::uint8_t>> record_bytes;
    read_group(file, kRecord, H5T_NATIVE_UINT8, record_bytes, path);
    const auto& text = record_bytes["json"];
    archive.record = Json::parse(std::string(text.begin(), text.end()), nullptr, false);
    if (archive.record.is_discarded()) throw InputError(fmt::format("'{}': its record is not JSON (a damaged checkpoint?)", path));
  } catch (...) {
    if (file >= 0) H5Fclose(file);
    H5Eset_auto2(H5E_DEFAULT, handler, data);
    throw;
  }
  H5Fclose(file);
  H5Eset_auto2(H5E_DEFAULT, handler, data);
  return archive;
}

}  // namespace iqmpm
