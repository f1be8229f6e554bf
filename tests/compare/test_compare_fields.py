"""Particle frames through meshio (XDMF + HDF5) and the field comparison."""

import numpy as np
import pytest

from compare import fields as fld
from compare.io import (CompareError, cell_field_at, list_vtk_times, particle_frame_at,
                        read_particle_frame)
from compare_synth import (hydrostatic_particles, write_foam_vtk, write_frames,
                           write_hand_xdmf)


def test_meshio_reads_frame_written_by_meshio(tmp_path):
    pts, p = hydrostatic_particles(0.1)
    write_frames(tmp_path, [(0.0, pts, p), (0.5, pts, 2 * p)])
    frame = particle_frame_at(tmp_path, 0.4)
    assert frame.time == 0.5
    assert frame.points.shape == (len(pts), 3)
    np.testing.assert_allclose(frame.pressure, 2 * p)
    assert frame.velocity.shape == (len(pts), 3)
    assert set(frame.material.tolist()) == {0}


def test_meshio_reads_hand_written_polyvertex_xdmf(tmp_path):
    pts = np.array([[0.1, 0.2, 0.0], [0.3, 0.4, 0.0], [0.5, 0.6, 0.0]])
    write_hand_xdmf(tmp_path / "frame_00000.xdmf", pts, np.array([1.0, 2.0, 3.0]),
                    np.array([0, 0, 1]))
    frame = read_particle_frame(tmp_path / "frame_00000.xdmf", 0.25)
    np.testing.assert_allclose(frame.points, pts)
    np.testing.assert_allclose(frame.pressure, [1, 2, 3])
    np.testing.assert_allclose(frame.velocity[:, :2], 1.0)
    assert frame.material.tolist() == [0, 0, 1]


def test_frame_missing_field_is_named(tmp_path):
    import meshio

    meshio.write(str(tmp_path / "f.xdmf"),
                 meshio.Mesh(np.zeros((2, 3)), [("vertex", np.array([[0], [1]]))],
                             point_data={"pressure": np.zeros(2)}))
    with pytest.raises(CompareError, match="missing point data 'velocity'"):
        read_particle_frame(tmp_path / "f.xdmf")


def test_hydrostatic_pressure_line_matches_analytic_and_cells(tmp_path):
    pts, p = hydrostatic_particles(0.02)
    write_frames(tmp_path / "ours", [(1.0, pts, p)])
    frame = particle_frame_at(tmp_path / "ours", 1.0)
    mine = fld.particle_pressure_line(frame, 0.5)
    exact = fld.hydrostatic_profile(mine.s, 0.5)
    assert fld.compare_profiles(mine, exact).rel_l2 < 1e-12
    assert fld.hydrostatic_particle_error(frame, 0.5) < 1e-12
    write_foam_vtk(tmp_path / "foam", [0.0, 1.0])
    times = [t for t, _ in list_vtk_times(tmp_path / "foam" / "VTK")]
    assert times == [0.0, 1.0]
    cells = cell_field_at(tmp_path / "foam", 0.9)
    assert cells.time == 1.0
    ref = fld.cell_pressure_line(cells, 0.5)
    e = fld.compare_profiles(mine, ref)
    assert e.rel_l2 < 1e-9  # both exact and linear in y
    # a 5 % pressure error shows up as 5 %
    frame.pressure[:] *= 1.05
    assert fld.compare_profiles(fld.particle_pressure_line(frame, 0.5), ref).rel_l2 == \
        pytest.approx(0.05, rel=1e-6)


def test_free_surface_particles_vs_cells(tmp_path):
    spacing = 0.01
    pts, _ = hydrostatic_particles(spacing, depth=1.0)
    level = lambda x: 0.3 + 0.1 * x  # noqa: E731
    keep = pts[:, 1] < level(pts[:, 0])
    pts = pts[keep]
    write_frames(tmp_path / "ours", [(0.2, pts, np.zeros(len(pts)))])
    mine = fld.particle_free_surface(particle_frame_at(tmp_path / "ours", 0.2))
    write_foam_vtk(tmp_path / "foam", [0.2], surface=level, nx=50, ny=50)
    ref = fld.cell_free_surface(cell_field_at(tmp_path / "foam", 0.2))
    np.testing.assert_allclose(ref.v, level(ref.s), atol=1e-12)
    e = fld.compare_profiles(mine, ref)
    assert e.max_abs < 2 * spacing
    assert e.rel_l2 < 0.02


def test_no_fluid_particles_is_a_clear_error(tmp_path):
    pts, p = hydrostatic_particles(0.1)
    write_frames(tmp_path, [(0.0, pts, p)])
    frame = particle_frame_at(tmp_path, 0.0)
    with pytest.raises(CompareError, match="no particles with material 3"):
        fld.particle_pressure_line(frame, 0.5, fluid_material=3)


def test_xdmf_meshio_cannot_read_is_a_clear_error(tmp_path):
    pts = np.array([[0.1, 0.2, 0.0], [0.3, 0.4, 0.0]])
    write_hand_xdmf(tmp_path / "frame_00000.xdmf", pts, np.zeros(2), np.zeros(2),
                    topology_data=False)
    with pytest.raises(CompareError, match="frame_00000.xdmf.*Topology with a DataItem"):
        read_particle_frame(tmp_path / "frame_00000.xdmf")
    (tmp_path / "junk.xdmf").write_text("not xml")
    with pytest.raises(CompareError, match="junk.xdmf"):
        read_particle_frame(tmp_path / "junk.xdmf")


def test_flat_vtk_layout_with_times_in_summary(tmp_path):
    write_foam_vtk(tmp_path, [0.0, 0.1, 0.2], flat=True, case="dam_break")
    entries = list_vtk_times(tmp_path / "VTK")
    assert [t for t, _ in entries] == [0.0, 0.1, 0.2]
    assert entries[1][1].name == "dam_break_0.1.vtu"
    assert cell_field_at(tmp_path, 0.12).time == 0.1
