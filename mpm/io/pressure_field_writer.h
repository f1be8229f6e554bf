// write_pressure_fields: every step's solved pressure fields as dense grid tensors, the
// dataset MPMNet learns from (mpmnet/README.md, "Dataset"). One HDF5 file per run,
// extended step by step (gzip, one chunk per step) under a temporary name that becomes
// pressure_fields.h5 when the run ends, so a reader never sees half a file.
#pragma once

#include <hdf5.h>

#include <string>
#include <vector>

#include "pressure/warm_start.h"

namespace iqmpm {

class PressureFieldWriter {
 public:
  // cells: dual cells per axis; origin: the domain's lower corner.
  PressureFieldWriter(const std::string& directory, const std::string& scene_name, Real dx, const std::vector<Real>& origin,
                      const std::vector<int>& cells);
  ~PressureFieldWriter();
  PressureFieldWriter(const PressureFieldWriter&) = delete;
  PressureFieldWriter& operator=(const PressureFieldWriter&) = delete;

  // One step: its fields (p_f, p_g, h by dual cell), dt, number and solve iterations.
  void append(const GridSolution& solution, double dt, long step, int iterations);
  // Closes the file and gives it its final name.
  void close();

 private:
  std::string path_;
  std::vector<hsize_t> frame_shape_;  // C, then the cells
  hid_t file_ = -1;
  hid_t fields_ = -1, active_ = -1, time_ = -1, dt_ = -1, step_ = -1, iterations_ = -1;
  hsize_t steps_ = 0;
  std::vector<float> values_;
  std::vector<unsigned char> masks_;
};

}  // namespace iqmpm
