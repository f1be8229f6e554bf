// Run outputs (benchmarks.md "Output contract"): particle frames as HDF5 with XDMF
// indices (one XDMF per frame for meshio, one temporal collection for ParaView),
// metrics.csv and summary.json. Every file is written to a temporary name and renamed,
// so a reader never sees half a file.
#pragma once

#include <string>
#include <vector>

#include "scene/json_reader.h"

namespace iqmpm {

struct ParticleFrame {
  double time = 0;
  int count = 0;
  std::vector<double> position;  // count x 3 (z = 0 in 2-D)
  std::vector<double> velocity;  // count x 3
  std::vector<double> pressure;  // count
  std::vector<int> material;     // count: 0 fluid, 1 + body index for solids
};

class OutputWriter {
 public:
  // Creates the folder (and frames/ when frames are written), removing an earlier run's
  // outputs (frames, particles.xdmf, metrics.csv, steps.csv, summary.json, checkpoint.h5,
  // pressure_fields.h5).
  OutputWriter(std::string directory, bool frames);
  // Continues a run in its folder (iqmpm resume): the frames listed in `written` (from
  // frames_written()) are kept, later ones (written after the checkpoint) removed.
  OutputWriter(std::string directory, bool frames, const Json& written);
  // The frames written so far: [[index, time, particles], ...].
  Json frames_written() const;
  void write_frame(const ParticleFrame& frame);
  void write_metrics(const std::vector<std::string>& columns, const std::vector<std::vector<double>>& rows) const;
  // A CSV table in the folder (metrics.csv, steps.csv), rewritten whole.
  void write_table(const std::string& name, const std::vector<std::string>& columns,
                   const std::vector<std::vector<double>>& rows) const;
  void write_summary(const Json& summary) const;
  const std::string& directory() const { return directory_; }

 private:
  void write_collection() const;
  std::string directory_;
  std::vector<std::pair<int, double>> frames_;  // (index, time)
  std::vector<int> counts_;
};

// Writes `text` to `path` through a temporary file and a rename.
void write_file_atomically(const std::string& path, const std::string& text);

}  // namespace iqmpm
