#include "io/output_writer.h"

#include <hdf5.h>

#include <cstring>
#include <filesystem>
#include <fmt/format.h>
#include <fstream>

#include "core/errors.h"

namespace iqmpm {
namespace fs = std::filesystem;

void write_file_atomically(const std::string& path, const std::string& text) {
  const std::string temporary = path + ".tmp";
  {
    std::ofstream out(temporary, std::ios::binary);
    if (!out) throw InputError(fmt::format("cannot write '{}'", path));
    out << text;
    if (!out) throw InputError(fmt::format("cannot write '{}' (disk full?)", path));
  }
  fs::rename(temporary, path);
}

OutputWriter::OutputWriter(std::string directory, bool frames) : directory_(std::move(directory)) {
  std::error_code ec;
  fs::create_directories(directory_, ec);
  if (ec) throw InputError(fmt::format("--out '{}': cannot create the output folder: {}", directory_, ec.message()));
  // An earlier run's outputs in the same folder would mix with this run's: remove what a
  // run writes (and nothing else).
  const fs::path root(directory_);
  for (const char* name : {"frames", "particles.xdmf", "metrics.csv", "steps.csv", "summary.json", "checkpoint.h5", "pressure_fields.h5"}) {
    fs::remove_all(root / name, ec);
    if (ec) throw InputError(fmt::format("--out '{}': cannot replace the earlier run's '{}': {}", directory_, name, ec.message()));
  }
  if (frames) fs::create_directories(root / "frames", ec);
  if (ec) throw InputError(fmt::format("--out '{}': cannot create the frames folder: {}", directory_, ec.message()));
}

OutputWriter::OutputWriter(std::string directory, bool frames, const Json& written) : directory_(std::move(directory)) {
  for (const auto& frame : written) {
    frames_.emplace_back(frame.at(0).get<int>(), frame.at(1).get<double>());
    counts_.push_back(frame.at(2).get<int>());
  }
  const fs::path frames_dir = fs::path(directory_) / "frames";
  std::error_code ec;
  if (frames) fs::create_directories(frames_dir, ec);
  if (ec) throw InputError(fmt::format("--out '{}': cannot create the frames folder: {}", directory_, ec.message()));
  // Frames the interrupted run wrote after its checkpoint: this run writes them again.
  for (int index = int(frames_.size());; ++index) {
    const fs::path stem = frames_dir / fmt::format("frame_{:05d}", index);
    if (!fs::exists(stem.string() + ".h5") && !fs::exists(stem.string() + ".xdmf")) break;
    fs::remove(stem.string() + ".h5", ec);
    fs::remove(stem.string() + ".xdmf", ec);
  }
}

Json OutputWriter::frames_written() const {
  Json written = Json::array();
  for (std::size_t i = 0; i < frames_.size(); ++i) written.push_back({frames_[i].first, frames_[i].second, counts_[i]});
  return written;
}

namespace {

// A string attribute `units` on a dataset (SI; "1" for a dimensionless index).
void write_units(hid_t set, const char* units) {
  const hid_t text = H5Tcopy(H5T_C_S1);
  H5Tset_size(text, std::strlen(units));
  const hid_t space = H5Screate(H5S_SCALAR);
  const hid_t attribute = H5Acreate2(set, "units", text, space, H5P_DEFAULT, H5P_DEFAULT);
  H5Awrite(attribute, text, units);
  H5Aclose(attribute);
  H5Sclose(space);
  H5Tclose(text);
}

void write_dataset(hid_t file, const char* name, hid_t type, int rows, int cols, const void* data, const char* units) {
  hsize_t dims[2] = {hsize_t(rows), hsize_t(cols)};
  hid_t space = H5Screate_simple(cols > 1 ? 2 : 1, dims, nullptr);
  // No modification times in the file: the same frame gives the same bytes (a resumed run
  // is compared with an uninterrupted one file by file).
  hid_t properties = H5Pcreate(H5P_DATASET_CREATE);
  H5Pset_obj_track_times(properties, false);
  hid_t set = H5Dcreate2(file, name, type, space, H5P_DEFAULT, properties, H5P_DEFAULT);
  H5Pclose(properties);
  if (rows > 0) H5Dwrite(set, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data);
  write_units(set, units);
  H5Dclose(set);
  H5Sclose(space);
}

std::string grid_xml(const std::string& h5, int count, double time, bool with_time) {
  std::string xml = fmt::format("<Grid Name=\"particles\" GridType=\"Uniform\">\n");
  if (with_time) xml += fmt::format("<Time Value=\"{:.10g}\"/>\n", time);
  xml += fmt::format(
      "<Topology TopologyType=\"Polyvertex\" NumberOfElements=\"{0}\" NodesPerElement=\"1\">\n"
      "<DataItem Dimensions=\"{0} 1\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">{1}:/connectivity</DataItem>\n"
      "</Topology>\n"
      "<Geometry GeometryType=\"XYZ\">\n"
      "<DataItem Dimensions=\"{0} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{1}:/position</DataItem>\n"
      "</Geometry>\n"
      "<Attribute Name=\"velocity\" AttributeType=\"Vector\" Center=\"Node\">\n"
      "<DataItem Dimensions=\"{0} 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{1}:/velocity</DataItem>\n"
      "</Attribute>\n"
      "<Attribute Name=\"pressure\" AttributeType=\"Scalar\" Center=\"Node\">\n"
      "<DataItem Dimensions=\"{0}\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">{1}:/pressure</DataItem>\n"
      "</Attribute>\n"
      "<Attribute Name=\"material\" AttributeType=\"Scalar\" Center=\"Node\">\n"
      "<DataItem Dimensions=\"{0}\" NumberType=\"Int\" Precision=\"4\" Format=\"HDF\">{1}:/material</DataItem>\n"
      "</Attribute>\n</Grid>\n",
      count, h5);
  return xml;
}

}  // namespace

void OutputWriter::write_frame(const ParticleFrame& frame) {
  const int index = int(frames_.size());
  const std::string stem = fmt::format("frame_{:05d}", index);
  const fs::path frames_dir = fs::path(directory_) / "frames";
  const std::string h5_path = (frames_dir / (stem + ".h5")).string();
  const std::string temporary = h5_path + ".tmp";
  hid_t file = H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  if (file < 0) throw InputError(fmt::format("cannot write '{}'", h5_path));
  std::vector<int> connectivity(frame.count);
  for (int i = 0; i < frame.count; ++i) connectivity[i] = i;
  write_dataset(file, "/connectivity", H5T_NATIVE_INT, frame.count, 1, connectivity.data(), "1");
  write_dataset(file, "/position", H5T_NATIVE_DOUBLE, frame.count, 3, frame.position.data(), "m");
  write_dataset(file, "/velocity", H5T_NATIVE_DOUBLE, frame.count, 3, frame.velocity.data(), "m/s");
  write_dataset(file, "/pressure", H5T_NATIVE_DOUBLE, frame.count, 1, frame.pressure.data(), "Pa");
  write_dataset(file, "/material", H5T_NATIVE_INT, frame.count, 1, frame.material.data(), "1");
  H5Fclose(file);
  fs::rename(temporary, h5_path);
  write_file_atomically((frames_dir / (stem + ".xdmf")).string(),
                        "<?xml version=\"1.0\"?>\n<Xdmf Version=\"3.0\">\n<Domain>\n" +
                            grid_xml(stem + ".h5", frame.count, frame.time, false) + "</Domain>\n</Xdmf>\n");
  frames_.emplace_back(index, frame.time);
  counts_.push_back(frame.count);
  write_collection();
}

void OutputWriter::write_collection() const {
  std::string xml = "<?xml version=\"1.0\"?>\n<Xdmf Version=\"3.0\">\n<Domain>\n"
                    "<Grid Name=\"particles\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
  std::string times = "frame,t\n";
  for (std::size_t i = 0; i < frames_.size(); ++i) {
    const std::string h5 = fmt::format("frames/frame_{:05d}.h5", frames_[i].first);
    xml += grid_xml(h5, counts_[i], frames_[i].second, true);
    times += fmt::format("{},{:.10g}\n", frames_[i].first, frames_[i].second);
  }
  xml += "</Grid>\n</Domain>\n</Xdmf>\n";
  write_file_atomically((fs::path(directory_) / "particles.xdmf").string(), xml);
  write_file_atomically((fs::path(directory_) / "frames" / "times.csv").string(), times);
}

void OutputWriter::write_metrics(const std::vector<std::string>& columns, const std::vector<std::vector<double>>& rows) const {
  write_table("metrics.csv", columns, rows);
}

void OutputWriter::write_table(const std::string& name, const std::vector<std::string>& columns,
                               const std::vector<std::vector<double>>& rows) const {
  std::string text;
  for (std::size_t c = 0; c < columns.size(); ++c) text += (c ? "," : "") + columns[c];
  text += "\n";
  for (const auto& row : rows) {
    for (std::size_t c = 0; c < row.size(); ++c) text += fmt::format("{}{:.10g}", c ? "," : "", row[c]);
    text += "\n";
  }
  write_file_atomically((fs::path(directory_) / name).string(), text);
}

void OutputWriter::write_summary(const Json& summary) const {
  write_file_atomically((fs::path(directory_) / "summary.json").string(), summary.dump(2) + "\n");
}

}  // namespace iqmpm
