"""The one table benchmark -> metrics -> references (documented in compare/README.md).

A benchmark name is a scene-file stem (``benchmarks/<dir>/<stem>.json``). Lookup falls back
to the folder name (``hydrostatic_2d`` -> ``hydrostatic``) and then to a generic entry that
compares every common column against interFoam.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

RHO_F = 1000.0
G = 9.81
DAM_A = 0.146  # dam_break column width a (m)
DAM_T_SCALE = math.sqrt(2.0 * G / DAM_A)  # T = t sqrt(2 g / a)


@dataclass(frozen=True)
class Normalisation:
    """Maps (t, y) in SI to the reference's dimensionless space: T = t*t_scale, Y = y*y_scale."""

    t_scale: float
    y_scale: float
    t_label: str
    y_label: str


@dataclass(frozen=True)
class CsvReference:
    """A series from a CSV in the data folder (its columns and row filter)."""

    key: str
    label: str
    file: str
    t_column: str
    y_column: str
    where: tuple[tuple[str, str], ...] = ()
    subtract_first: bool = False  # digitisation offset (the file header says so)
    max_y: float | None = None  # drop reference points beyond this (outside the set-up)
    max_t: float | None = None  # drop reference points after this time (the error window)
    normalised: bool = False  # the CSV is in the metric's Normalisation space


@dataclass(frozen=True)
class ConstantReference:
    """An analytic value that the whole series should equal."""

    key: str
    label: str
    value: float


Reference = CsvReference | ConstantReference


@dataclass(frozen=True)
class MetricSpec:
    column: str
    unit: str
    description: str
    references: tuple[Reference, ...] = ()
    against_foam: bool = True
    use_abs: bool = False  # compare |y| (sign convention of a wall force not fixed)
    normalisation: Normalisation | None = None
    # drop samples at t <= 0: forces and pressures exist only after the first pressure solve
    skip_initial: bool = False
    # a quantity whose true value is zero (the rotation of a heaving symmetric body): any
    # reference is noise about zero, so errors are absolute (RMS difference, peak difference in
    # the metric's unit) and the relative L2 / peak error are not reported
    absolute: bool = False
    # a value per step, held over the step (a force: the step's impulse over dt): against
    # interFoam also compared as its mean over each interFoam sample's interval
    # (errors.interval_means), besides the raw series
    per_step: bool = False


@dataclass(frozen=True)
class ScalarSpec:
    """A scalar from summary.json (``summary_key``) or reduced from a metric series.

    ``reducer``: "first" (first sample at t > 0), "last", "max", "mean_tail" (mean over the last
    ``tail`` fraction of the run), "mean_periods" (time average over the whole periods of the
    tail: the equilibrium of a decaying oscillation), "period" (the period of a damped sinusoid
    fitted over the whole run, with its uncertainty), "frequency" (1/period), "decay"
    (amplitude ratio per period, exp(-rate period), of the damped sinusoid fitted over the
    first two periods from the release, with its uncertainty), "early_period" (the period of a damped sinusoid
    fitted over the first two periods from the release, with its uncertainty), "window_peak"
    (the largest mean over a sliding window of ``window`` seconds, e.g. a force without its
    single-step spikes), "integral" (the time integral from ``start`` up to ``until`` seconds,
    or over the run: an impulse), "window_mean" (the time average from ``start`` to
    ``until``), "std_tail" (the standard deviation over the last ``tail`` fraction: the noise
    of a quantity that should hold still), "largest_change" (the relative change from the
    first sample farthest from zero, with its sign: a volume that dips and recovers). With
    ``subtract_column`` the series reduced is ``column - subtract_column + offset`` (e.g. a
    draft: water level - centre height + half the body's height).
    """

    name: str
    unit: str
    description: str
    reference: float | None = None  # None: compare with interFoam's value, if any
    reference_label: str = ""
    summary_key: str | None = None
    column: str | None = None
    reducer: str = "last"
    tail: float = 0.5
    use_abs: bool = False
    subtract_column: str | None = None
    offset: float = 0.0
    window: float = 0.0  # s, for "window_peak"
    until: float | None = None  # s, for "integral" and "window_mean"
    start: float | None = None  # s, for "integral" and "window_mean" (None: the first sample)
    # |reference| at or below this (in ``unit``) counts as zero: the error is reported as an
    # absolute one (value - reference, with the unit), the relative one as n/a. 0: only an
    # exact zero (the default); ``absolute=True``: always absolute.
    zero_floor: float = 0.0
    absolute: bool = False


@dataclass(frozen=True)
class FieldSpec:
    """A field comparison at chosen times.

    kind "pressure_line": pressure along the vertical line x = ``x`` (particles vs cells,
    and vs rho_f g (H - y) when ``hydrostatic_depth`` is set). kind "free_surface":
    surface elevation against x.
    """

    kind: str
    times: tuple[float, ...]
    x: float | None = None
    hydrostatic_depth: float | None = None


@dataclass(frozen=True)
class Benchmark:
    name: str
    title: str
    dim: int
    foam_case: str | None
    metrics: tuple[MetricSpec, ...] = ()
    scalars: tuple[ScalarSpec, ...] = ()
    fields: tuple[FieldSpec, ...] = ()
    # (metric column, reference key, "foam": the finest interFoam run, or "self": each
    # solver's own finest run) measured in the run time against error
    primary: tuple[str, str] | None = None
    generic: bool = False
    # in `compare validate` without --benchmark (the README's main job); long runs are not
    quick: bool = True
    # Seconds a run of this benchmark may take at least (validate uses the larger of this
    # and --timeout): a long benchmark must not die at the default 900 s.
    min_timeout: float = 0.0
    # its OpenFOAM case at level 1 in the quick suite; a slow one (minutes) runs only when
    # the benchmark is named or with --full (a cached run with unchanged inputs is still used)
    foam_quick: bool = True
    # typical wall time (s, one thread, default resolution; OpenFOAM level 1): validate
    # starts the longest runs first when it has no earlier run to go by
    cost_s: float = 10.0
    foam_cost_s: float = 20.0

    def metric(self, column: str) -> MetricSpec | None:
        for spec in self.metrics:
            if spec.column == column:
                return spec
        return None


FORCE_2D = "N/m"
DAM_NORM = Normalisation(DAM_T_SCALE, 1.0 / DAM_A, "T = t sqrt(2g/a) (-)", "Z = front x / a (-)")

_DAM_FRONT_REFS: tuple[Reference, ...] = (
    CsvReference("ko1996", "Koshizuka & Oka (1996), exp.",
                 "koshizuka_oka_1996_surge_front_pysph.csv",
                 "T_t_sqrt_2g_over_L", "Z_x_over_L", max_y=4.0, max_t=2.5, normalised=True),
    CsvReference("mm1952", "Martin & Moyce (1952), n^2=2 (Lethe)",
                 "martin_moyce_1952_n2_2_front_lethe.csv",
                 "tau_t_sqrt_2g_over_L", "x_front_over_L", max_y=4.0, max_t=2.5, normalised=True),
    CsvReference("mm1952_a1125", "Martin & Moyce (1952), a=1.125 in",
                 "martin_moyce_1952_surge_front_pysph.csv",
                 "T_t_sqrt_2g_over_a", "Z_x_over_a", where=(("case_a_inch", "1.125"),),
                 max_y=4.0, max_t=2.5, normalised=True),
    CsvReference("mm1952_a225", "Martin & Moyce (1952), a=2.25 in",
                 "martin_moyce_1952_surge_front_pysph.csv",
                 "T_t_sqrt_2g_over_a", "Z_x_over_a", where=(("case_a_inch", "2.25"),),
                 max_y=4.0, max_t=2.5, normalised=True),
)

_GATE_FILE = "antoci2007_elastic_gate_tip_displacement.csv"


def _gate_refs(component: str) -> tuple[Reference, ...]:
    names = (("experiment", "Antoci et al. (2007), exp."),
             ("antoci_sph", "Antoci et al. (2007), SPH"),
             ("yang2012_sph_fem", "Yang et al. (2012), SPH-FEM"))
    return tuple(
        CsvReference(f"{series}_{component}", label, _GATE_FILE, "t_s", "disp_m",
                     where=(("series", series), ("component", component)), subtract_first=True)
        for series, label in names
    )


HYDRO_H = 0.5
HYDRO_FORCE = RHO_F * G * HYDRO_H**2 / 2.0  # 1226.25 N/m
HYDRO_DEPTH_3D = 1.0  # wall width of the 3-D box (m); force = HYDRO_FORCE * width


def _hydrostatic(name: str, dim: int) -> Benchmark:
    width = 1.0 if dim == 2 else HYDRO_DEPTH_3D
    force_unit = FORCE_2D if dim == 2 else "N"
    return Benchmark(
        name=name,
        title=f"Water at rest ({dim}-D)",
        dim=dim,
        foam_case="hydrostatic" if dim == 2 else None,
        metrics=(
            MetricSpec("wall_force_x", force_unit, "force on a side wall",
                       (ConstantReference("analytic", "rho g H^2/2", HYDRO_FORCE * width),),
                       use_abs=True, skip_initial=True),
            MetricSpec("max_speed", "m/s", "largest particle speed (spurious currents)",
                       against_foam=False),  # both near 0: a relative error means nothing
            MetricSpec("volume", "m^2" if dim == 2 else "m^3", "fluid volume",
                       against_foam=False),
        ),
        scalars=(
            ScalarSpec("wall_force_final", force_unit, "wall force at the end",
                       reference=HYDRO_FORCE * width, reference_label="rho g H^2/2",
                       column="wall_force_x", reducer="last", use_abs=True),
            ScalarSpec("max_speed_final", "m/s", "largest speed at the end", reference=0.0,
                       reference_label="0", column="max_speed", reducer="last"),
            ScalarSpec("pressure_l2_error", "-", "solver's relative L2 pressure error",
                       reference=0.0, reference_label="0", summary_key="pressure_l2_error"),
            ScalarSpec("volume_drift", "-", "relative volume drift", reference=0.0,
                       reference_label="0", summary_key="volume_drift"),
        ),
        fields=(FieldSpec("pressure_line", (2.0,), x=0.5, hydrostatic_depth=HYDRO_H),),
        primary=("wall_force_x", "analytic"),
    )


REGISTRY: dict[str, Benchmark] = {}

# Typical wall times on the 2-core reference machine (one thread, default
# resolution; OpenFOAM level 1, set-up and VTK included): (IQ-MPM s, OpenFOAM s). They only
# order validate's queue, longest first.
_COST_S: dict[str, tuple[float, float]] = {
    "hydrostatic_2d": (3, 15), "hydrostatic_3d": (75, 0), "dam_break": (6, 20),
    "dam_break_obstacle": (12, 30), "elastic_gate": (55, 0), "submerged_plate": (4, 0),
    "submerged_block": (12, 0), "neutral_block": (95, 0), "floating_block": (115, 480),
    "floating_block_roll": (155, 500), "floating_block_light": (110, 720),
    "floating_block_3d": (90, 0), "floating_block_3d_fine": (1000, 0),
    "elastic_sphere": (250, 0), "cantilever": (15, 25), "cantilever_vibration": (6, 0),
    "cantilever_vibration_adaptive": (6, 0),
    "cantilever_large_deflection": (20, 0),
}


def _register(b: Benchmark) -> None:
    if b.name in _COST_S:
        b = replace(b, cost_s=float(_COST_S[b.name][0]), foam_cost_s=float(_COST_S[b.name][1]))
    REGISTRY[b.name] = b


_register(_hydrostatic("hydrostatic_2d", 2))
_register(_hydrostatic("hydrostatic_3d", 3))

# The water's volume over the run (issue 23 item 6: within 2 % at every step, not only at
# the end): the `volume` probe's relative change farthest from the start.
VOLUME_LARGEST_CHANGE = ScalarSpec(
    "volume_largest_change", "-", "relative change of the water's volume farthest from the start over the run",
    reference=0.0, reference_label="0", column="volume", reducer="largest_change")


_register(Benchmark(
    name="dam_break",
    title="Collapsing water column (Koshizuka & Oka set-up)",
    dim=2,
    foam_case="dam_break",
    metrics=(
        MetricSpec("front_x", "m", "surge front on the floor", _DAM_FRONT_REFS,
                   normalisation=DAM_NORM),
        MetricSpec("height_left", "m", "water height at the left wall"),
        MetricSpec("pressure_right", "Pa", "pressure on the right wall 0.01 m above the floor",
                   skip_initial=True, per_step=True),
        *(MetricSpec(f"pressure_right_{cm}cm", "Pa", f"pressure on the right wall 0.{cm:02d} m above the floor",
                     skip_initial=True, per_step=True) for cm in (3, 6, 10)),
        MetricSpec("volume", "m^2", "fluid volume", against_foam=False),
    ),
    scalars=(
        ScalarSpec("volume_drift", "-", "relative volume drift", reference=0.0,
                   reference_label="0", summary_key="volume_drift"),
        VOLUME_LARGEST_CHANGE,
        # Windowed wall pressure (issue 23 item 4): over 0.35-0.5 s, while the run-up climbs
        # the wall, interFoam's 80^2 and 160^2 levels agree within 5 % at 1, 3 and 6 cm
        # (docs/benchmarks.md, dam_break).
        *(ScalarSpec(f"{column}_mean_0.35-0.5s", "Pa",
                     f"mean pressure on the right wall {height} m above the floor over 0.35-0.5 s",
                     column=column, reducer="window_mean", start=0.35, until=0.5)
          for column, height in (("pressure_right", "0.01"), ("pressure_right_3cm", "0.03"),
                                 ("pressure_right_6cm", "0.06"), ("pressure_right_10cm", "0.1"))),
    ),
    fields=(
        FieldSpec("free_surface", (0.1, 0.2, 0.3)),
        FieldSpec("pressure_line", (0.3, 0.5), x=0.55),
    ),
    # Run time against error against each solver's own finest run: the experiment, and
    # interFoam's finest level, differ from IQ-MPM's converged front by more than either
    # solver's grid error (docs/benchmarks.md).
    primary=("front_x", "self"),
))

_register(Benchmark(
    name="dam_break_obstacle",
    title="Dam break on a stiff obstacle (interFoam damBreak tutorial)",
    dim=2,
    foam_case="dam_break_obstacle",
    metrics=(
        MetricSpec("obstacle_force_x", FORCE_2D, "horizontal force on the obstacle",
                   skip_initial=True, per_step=True),
        MetricSpec("front_x", "m", "surge front on the floor"),
        MetricSpec("height_left", "m", "water height at the left wall"),
    ),
    scalars=(
        # The force has single-step spikes (docs/method.md#12-known-limits); its 10 ms means and impulses
        # are what compares with interFoam.
        ScalarSpec("force_peak_10ms", FORCE_2D, "largest 10 ms mean of the obstacle force",
                   column="obstacle_force_x", reducer="window_peak", window=0.01),
        ScalarSpec("impulse_to_0.3s", "N s/m", "impulse of the obstacle force up to 0.3 s (the first impact)",
                   column="obstacle_force_x", reducer="integral", until=0.3),
        ScalarSpec("impulse", "N s/m", "impulse of the obstacle force over the run",
                   column="obstacle_force_x", reducer="integral"),
        VOLUME_LARGEST_CHANGE,
    ),
    fields=(FieldSpec("free_surface", (0.2, 0.4)),),
    primary=("obstacle_force_x", "foam"),
))

_register(Benchmark(
    name="elastic_gate",
    title="Dam break through a rubber gate (Antoci et al. 2007)",
    dim=2,
    foam_case=None,
    metrics=(
        MetricSpec("gate_tip_dx", "m", "gate-tip horizontal displacement", _gate_refs("x")),
        MetricSpec("gate_tip_dy", "m", "gate-tip vertical displacement", _gate_refs("y")),
        MetricSpec("gate_force_x", FORCE_2D, "horizontal water force on the gate", skip_initial=True),
    ),
    scalars=(
        ScalarSpec("gate_tip_dx_peak", "m", "peak tip horizontal displacement", reference=0.0463,
                   reference_label="experiment", column="gate_tip_dx", reducer="max"),
        # The released gate starts unloaded: at t = 0+ only its inertia holds the water, so
        # the hydrostatic 77.9 N/m is the plate variant's check (submerged_plate), not this one.
        ScalarSpec("gate_force_initial", FORCE_2D, "gate force at t = 0+ (unloaded gate)",
                   column="gate_force_x", reducer="first"),
    ),
    primary=("gate_tip_dx", "experiment_x"),
))


def _force_at_rest(name: str, title: str, column: str, what: str, reference: float, label: str,
                   tail: float) -> Benchmark:
    """A body held in water at rest: an interface-force series against a constant."""
    return Benchmark(
        name=name,
        title=title,
        dim=2,
        foam_case=None,
        metrics=(MetricSpec(column, FORCE_2D, what, (ConstantReference("hydrostatic", label, reference),),
                            skip_initial=True),),
        scalars=(ScalarSpec(f"{column}_mean", FORCE_2D, f"{what}, mean over the last {100 * tail:.0f} %",
                            reference=reference, reference_label=label, column=column,
                            reducer="mean_tail", tail=tail),
                 # issue 23 item 3: a body at rest feels a steady force; its standard
                 # deviation is the step-to-step noise of the interface force
                 ScalarSpec(f"{column}_std", FORCE_2D, f"{what}, standard deviation over the last {100 * tail:.0f} %",
                            reference=0.0, reference_label="0 (at rest)", column=column,
                            reducer="std_tail", tail=tail)),
        primary=(column, "hydrostatic"),
    )


_register(_force_at_rest("submerged_plate", "Hydrostatic force on a stiff gate (plate variant of submerged_block)",
                         "gate_force_x", "horizontal force on the gate's free part", 77.9,
                         "hydrostatic integral", 0.6))
_register(_force_at_rest("submerged_block", "Interface force at rest on a clamped block", "block_force_y",
                         "vertical interface force on the block", RHO_F * G * 0.02, "rho g V", 0.5))


# The rest test: a free block as dense as the water stays put (speed < 1e-3 m/s at 1 s).
_register(Benchmark(
    name="neutral_block",
    title="Neutrally buoyant block at rest (submerged_block released, rho_s = rho_f)",
    dim=2,
    foam_case=None,
    metrics=(MetricSpec("com_y", "m", "block centre height", (ConstantReference("rest", "initial height", 0.25),)),
             MetricSpec("block_velocity_y", "m/s", "block mean vertical velocity"),
             MetricSpec("block_force_y", FORCE_2D, "vertical interface force on the block",
                        (ConstantReference("weight", "weight = rho g V", RHO_F * G * 0.02),), skip_initial=True),
             MetricSpec("max_speed", "m/s", "largest particle speed (spurious currents)")),
    scalars=(
        ScalarSpec("block_velocity_y_end", "m/s", "block vertical velocity, mean over the last 20 % (criterion: "
                   "below 1e-3 m/s in size)", reference=0.0, reference_label="at rest", column="block_velocity_y",
                   reducer="mean_tail", tail=0.2),
        ScalarSpec("com_y_final", "m", "block centre height at the end", reference=0.25,
                   reference_label="initial height", column="com_y", reducer="last"),
    ),
    primary=("com_y", "rest"),
))


def _floating(name: str, title: str, equilibrium_com_y: float, draft: float, roll: bool = False,
              quick: bool = True) -> Benchmark:
    scalars = [
        ScalarSpec("equilibrium_com_y", "m", "centre height, mean over last 40 %",
                   reference=equilibrium_com_y, reference_label="Archimedes", column="com_y",
                   reducer="mean_tail", tail=0.4),
        # The criterion (benchmarks.md): the still-water level far from the block (water_level
        # probe, x = 0.02-0.3 m) minus the block's bottom (centre - 0.05 m), over the last 40 %.
        # The centre height alone hides it: 1 cm of draft is 2 % of 0.504 m but 20 % of 0.05 m.
        ScalarSpec("equilibrium_draft", "m", "draft: still-water level - block bottom, mean over last 40 %",
                   reference=draft, reference_label="Archimedes", column="water_level",
                   subtract_column="com_y", offset=0.05, reducer="mean_tail", tail=0.4),
        ScalarSpec("heave_period", "s", "heave period, first two periods", column="com_y",
                   reducer="early_period", tail=0.4),
        ScalarSpec("heave_decay", "-", "heave amplitude ratio per period, fitted over the first two periods",
                   column="com_y", reducer="decay"),
    ]
    if roll:
        scalars.append(ScalarSpec("roll_period", "s", "roll period, first two periods", column="angle",
                                  reducer="early_period", tail=0.4))
        scalars.append(ScalarSpec("roll_decay", "-", "roll amplitude ratio per period, fitted over the first two periods",
                                  column="angle", reducer="decay"))
    scalars.append(ScalarSpec("volume_drift", "-", "relative volume drift", reference=0.0,
                              reference_label="0", summary_key="volume_drift"))
    return Benchmark(
        name=name,
        title=title,
        dim=2,
        foam_case=name,
        metrics=(
            MetricSpec("com_y", "m", "block centre height"),
            MetricSpec("com_x", "m", "block centre x"),
            # released level, a heaving block's rotation is zero by symmetry: both solvers'
            # angles are noise about it, compared in radians, not relative to each other
            MetricSpec("angle", "rad", "block rotation", absolute=not roll),
            MetricSpec("volume", "m^2", "fluid volume", against_foam=False),
        ),
        scalars=tuple(scalars),
        primary=("com_y", "foam"),
        quick=quick,
        # interFoam (overset) takes 8-12 min at level 1 on a fresh 2-core machine: the
        # floating blocks' interFoam references (periods, decay) belong to the full suite;
        # their checks (Archimedes draft, volume) need no OpenFOAM run.
        foam_quick=False,
    )


# Archimedes with the water area 0.494 m^2 of the tank (1 m wide): the still-water level is
# 0.494 + 0.2 d for a draft d = rho_s / rho_f * 0.1 m, the centre 0.05 m above level - d.
_register(_floating("floating_block", "Floating block: buoyancy and heave decay", 0.504, 0.05))
# The roll and light cases each cost about 2.5 min here and 8 min of interFoam on a fresh
# machine: named runs only.
_register(_floating("floating_block_roll", "Floating block released tilted 10 degrees: roll decay", 0.504, 0.05,
                    roll=True, quick=False))
_register(_floating("floating_block_light", "Light floating block (rho_s = 200): heave", 0.528, 0.02, quick=False))

def _floating_cube(name: str, title: str, centre: float, min_timeout: float = 0.0) -> Benchmark:
    """The 3-D cube (side 0.2 m, rho_s = 500); `centre`: its Archimedes centre height, m."""
    return Benchmark(
        name=name,
        title=title,
        dim=3,
        foam_case=None,
        metrics=(MetricSpec("com_y", "m", "cube centre height",
                            (ConstantReference("archimedes", "Archimedes", centre),)),
                 MetricSpec("block_force_y", "N", "vertical interface force on the cube",
                            (ConstantReference("weight", "weight", 500 * 0.008 * G),), skip_initial=True)),
        scalars=(
            ScalarSpec("equilibrium_com_y", "m", "centre height, mean over last 40 %", reference=centre,
                       reference_label="Archimedes", column="com_y", reducer="mean_tail", tail=0.4),
            # The cube tips over, but any plane through its centre halves it: at
            # equilibrium the centre sits at the still-water level in any orientation, so
            # level - centre + 0.1 m is the draft of the upright cube.
            ScalarSpec("equilibrium_draft", "m", "draft: still-water level - (centre - 0.1 m), mean over last 40 %",
                       reference=0.1, reference_label="Archimedes", column="water_level",
                       subtract_column="com_y", offset=0.1, reducer="mean_tail", tail=0.4),
            # The same against the hydrostatic head far from the cube (p / (rho_f g) +
            # height): the column tops of `water_level` read a few mm high in 3-D
            # (docs/method.md#12-known-limits).
            ScalarSpec("head_draft", "m", "draft: hydrostatic head far from the cube - (centre - 0.1 m), mean over last 40 %",
                       reference=0.1, reference_label="Archimedes", column="still_water_level",
                       subtract_column="com_y", offset=0.1, reducer="mean_tail", tail=0.4),
            ScalarSpec("volume_drift", "-", "relative volume drift", reference=0.0,
                       reference_label="0", summary_key="volume_drift"),
        ),
        primary=("com_y", "archimedes"),
        quick=False,
        min_timeout=min_timeout,
    )


_register(_floating_cube("floating_block_3d", "Floating cube (3-D)", 0.5028))
# About 12 min on two threads at dt_max 2.5 ms with the position correction (docs/benchmarks.md);
# one thread is slower.
_register(_floating_cube("floating_block_3d_fine", "Floating cube (3-D), dx 0.025, 0.6 m tank, dt 2.5 ms", 0.5078,
                         min_timeout=4 * 3600))

_register(Benchmark(
    name="elastic_sphere",
    title="Soft ball dropped into water (3-D stress test, no reference)",
    dim=3,
    foam_case=None,
    metrics=(MetricSpec("com_y", "m", "ball centre height"),
             MetricSpec("ball_force_y", "N", "vertical interface force on the ball", skip_initial=True),
             MetricSpec("max_speed", "m/s", "largest particle speed")),
    quick=False,
))

_CANT_E, _CANT_NU, _CANT_L, _CANT_T, _CANT_RHO = 1e8, 0.3, 0.5, 0.05, 1000.0
_CANT_TIP = -3.386e-3  # m (downward), benchmarks.md
_CANT_FREQ = 10.7  # Hz

# The beam's tip, its sag and frequency against beam theory, and the amplitude it keeps a
# period (no damping in the model: 1), shared by the two cantilever scenes.
_CANT_METRICS = (MetricSpec("tip_dy", "m", "tip vertical displacement"),
                 MetricSpec("tip_dx", "m", "tip horizontal displacement"))
_CANT_STATIC = ScalarSpec("static_tip_dy", "m", "static tip deflection (mean over whole periods of the 2nd half)",
                          reference=_CANT_TIP, reference_label="Euler-Bernoulli + shear",
                          column="tip_dy", reducer="mean_periods", tail=0.5)
_CANT_FREQUENCY = ScalarSpec("first_frequency", "Hz", "first bending frequency", reference=_CANT_FREQ,
                             reference_label="beam theory", column="tip_dy", reducer="frequency")
_CANT_DECAY = ScalarSpec("amplitude_decay", "-", "amplitude kept per period, fitted over the first two periods",
                         reference=1.0, reference_label="undamped beam", column="tip_dy", reducer="decay")

# amplitude_decay here is implicit Euler's damping at the scene's 93 steps a period (no criterion)
_register(Benchmark(
    name="cantilever",
    title="Cantilever under gravity (solid only)",
    dim=2,
    foam_case="cantilever",
    metrics=_CANT_METRICS,
    scalars=(_CANT_STATIC, _CANT_FREQUENCY, _CANT_DECAY),
    primary=("tip_dy", "foam"),
))

def _cantilever_vibration(name: str, title: str) -> Benchmark:
    """The beam's free vibration under the midpoint rule, against the undamped beam."""
    return Benchmark(name=name, title=title, dim=2, foam_case=None, metrics=_CANT_METRICS,
                     scalars=(_CANT_DECAY, _CANT_FREQUENCY, _CANT_STATIC))


# Issue 23 item 2: at 40 steps a period (dt_max), and with the time step set by the solid's
# error estimate (solid_step_error) instead.
_register(_cantilever_vibration("cantilever_vibration", "Cantilever in free vibration, midpoint rule (solid only)"))
_register(_cantilever_vibration(
    "cantilever_vibration_adaptive",
    "Cantilever in free vibration, midpoint rule, time step from the solid's error (solid only)"))

# The same beam 1/100 as stiff under a gravity ramp: the static tip at large deflection vs the
# elastica (benchmarks/cantilever/elastica.py), over the last second (the ramp ends at 3 s).
_CANT_LARGE_DY, _CANT_LARGE_DX = -0.2590, -0.0844  # m
_register(Benchmark(
    name="cantilever_large_deflection",
    title="Cantilever bent to 42 degrees by its own weight (solid only)",
    dim=2,
    foam_case=None,
    metrics=_CANT_METRICS,
    scalars=(
        ScalarSpec("static_tip_dy", "m", "tip vertical displacement, mean over the last sixth of the run",
                   reference=_CANT_LARGE_DY, reference_label="elastica", column="tip_dy", reducer="mean_tail",
                   tail=1 / 6),
        ScalarSpec("static_tip_dx", "m", "tip horizontal displacement, mean over the last sixth of the run",
                   reference=_CANT_LARGE_DX, reference_label="elastica", column="tip_dx", reducer="mean_tail",
                   tail=1 / 6),
    ),
))


UNITS: dict[str, str] = {
    "front_x": "m", "height_left": "m", "pressure_right": "Pa", "wall_force_x": FORCE_2D,
    "max_speed": "m/s", "volume": "m^2", "tip_dx": "m", "tip_dy": "m", "gate_tip_dx": "m",
    "gate_tip_dy": "m", "gate_force_x": FORCE_2D, "com_x": "m", "com_y": "m", "angle": "rad",
    "block_force_x": FORCE_2D, "block_force_y": FORCE_2D, "obstacle_force_x": FORCE_2D,
}


# other names of registry entries (a scene or folder called "hydrostatic" is the 2-D one)
ALIASES: dict[str, str] = {"hydrostatic": "hydrostatic_2d"}


def lookup(name: str, folder: str | None = None) -> Benchmark:
    """Registry entry for a scene stem, else its folder, else a generic entry."""
    for key in (name, folder):
        key = ALIASES.get(key, key) if key else key
        if key and key in REGISTRY:
            return REGISTRY[key] if key == name else replace(REGISTRY[key], name=name)
    return Benchmark(name=name, title=name, dim=2, foam_case=folder or name, generic=True)


def generic_metrics(columns: list[str]) -> tuple[MetricSpec, ...]:
    return tuple(MetricSpec(c, UNITS.get(c, "?"), c) for c in columns)


def _ref_text(ref: Reference) -> str:
    if isinstance(ref, ConstantReference):
        return f"{ref.label} = {ref.value:g}"
    extra = []
    if ref.where:
        extra.append(", ".join(f"{k}={v}" for k, v in ref.where))
    if ref.subtract_first:
        extra.append("first value subtracted")
    if ref.max_y is not None:
        extra.append(f"points with y <= {ref.max_y:g}")
    if ref.max_t is not None:
        extra.append(f"points with t <= {ref.max_t:g}")
    tail = f" ({'; '.join(extra)})" if extra else ""
    return f"{ref.label}: `{ref.file}`{tail}"


def registry_markdown() -> str:
    """The registry as a Markdown table (pasted into compare/README.md)."""
    lines = ["| benchmark | OpenFOAM case | quantity | unit | references |",
             "|---|---|---|---|---|"]
    for b in REGISTRY.values():
        for m in b.metrics:
            refs = [_ref_text(r) for r in m.references]
            if m.against_foam and b.foam_case:
                refs.append("interFoam")
            name = f"`{m.column}`" + (" (abs)" if m.use_abs else "")
            if m.normalisation:
                name += " in (T, Z)"
            if m.skip_initial:
                name += ", t > 0"
            if m.absolute:
                name += " (absolute)"
            lines.append(f"| {b.name} | {b.foam_case or '-'} | {name} | {m.unit} | "
                         f"{'; '.join(refs) or '-'} |")
        for s in b.scalars:
            series = f"`{s.column}`"
            if s.subtract_column:
                series += f" - `{s.subtract_column}` + {s.offset:g}"
            reducer = s.reducer
            if s.reducer == "window_peak":
                reducer = f"window_peak[{s.window:g} s]"
            elif s.reducer in ("integral", "window_mean") and (s.start is not None or s.until is not None):
                begin = "0" if s.start is None else f"{s.start:g}"
                end = "end" if s.until is None else f"{s.until:g} s"
                reducer = f"{s.reducer}[{begin}, {end}]"
            src = f"summary `{s.summary_key}`" if s.summary_key else f"{reducer}({series})"
            if s.absolute:
                src += " (absolute)"
            elif s.zero_floor > 0:
                src += f" (absolute when the reference is within {s.zero_floor:g} {s.unit} of 0)"
            if s.reference is not None:
                ref = (f"{s.reference:g}" if s.reference_label == f"{s.reference:g}"
                       else f"{s.reference_label} = {s.reference:g}")
            else:
                ref = "interFoam" if b.foam_case else "-"
            lines.append(f"| {b.name} | {b.foam_case or '-'} | {s.name}: {src} | {s.unit} | "
                         f"{ref} |")
        for f in b.fields:
            where = f" at x = {f.x:g} m" if f.x is not None else ""
            ref = "interFoam" if b.foam_case else "-"
            if f.hydrostatic_depth is not None:
                ref += f"; rho g (H - y), H = {f.hydrostatic_depth:g} m"
            times = ", ".join(f"{t:g}" for t in f.times)
            lines.append(f"| {b.name} | {b.foam_case or '-'} | field {f.kind}{where}, "
                         f"t = {times} s | {'Pa' if f.kind == 'pressure_line' else 'm'} | "
                         f"{ref} |")
    return "\n".join(lines)
