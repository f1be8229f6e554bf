"""The module the solver loads: shapes, masks, the normalisation, scripting, the file."""

import json

import pytest
import torch

from mpmnet import model

T = 4


def _inputs(spatial, seed=0, scale=1e4):
    g = torch.Generator().manual_seed(seed)
    C = 3
    history_active = (torch.rand((T, C) + spatial, generator=g) > 0.3).float()
    base = torch.rand((C,) + spatial, generator=g) * scale
    steps = torch.arange(T, dtype=torch.float32).reshape((T, 1) + (1,) * len(spatial))
    history = (base * (1 + 0.01 * steps)) * history_active
    next_active = (torch.rand((C,) + spatial, generator=g) > 0.3).float()
    return history, history_active, next_active


def _randomised(dim, seed=1):
    """A module with random weights everywhere (the trained-from-zero last layer too), so
    that its output is not the trivial last frame."""
    torch.manual_seed(seed)
    module = model.build(dim)
    with torch.no_grad():
        for p in module.parameters():
            p.normal_(0.0, 0.2)
    return module.eval()


@pytest.mark.parametrize("dim, spatial", [(2, (37, 21)), (3, (9, 7, 5))])
def test_scripted_output_has_the_input_shape_and_is_zero_outside_next_active(dim, spatial):
    scripted = torch.jit.script(_randomised(dim))
    history, history_active, next_active = _inputs(spatial)
    with torch.no_grad():
        out = scripted(history, history_active, next_active)
    assert out.shape == (3,) + spatial and out.dtype == torch.float32
    assert torch.all(out[next_active == 0] == 0)
    assert torch.count_nonzero(out[next_active == 1]) > 0.9 * int(next_active.sum())
    assert torch.isfinite(out).all()


@pytest.mark.parametrize("dim, spatial", [(2, (37, 21)), (3, (9, 7, 5))])
def test_scripted_equals_eager_and_a_batch_equals_single_calls(dim, spatial):
    module = _randomised(dim)
    scripted = torch.jit.script(module)
    a, b = _inputs(spatial, 0), _inputs(spatial, 1)
    with torch.no_grad():
        batched = module.predict(*(torch.stack([x, y]) for x, y in zip(a, b)))
        for single, inputs in ((batched[0], a), (batched[1], b)):
            out = scripted(*inputs)
            assert float((out - single).abs().max()) <= 1e-5 * float(single.abs().max())


@pytest.mark.parametrize("dim, spatial", [(2, (37, 21)), (3, (9, 7, 5))])
def test_the_untrained_module_returns_the_last_frame_exactly(dim, spatial):
    """The normalisation round trip: the last layer starts at zero (no change), and the
    prediction in Pa must then be the last frame, masked by next_active, bit for bit."""
    scripted = torch.jit.script(model.build(dim).eval())
    history, history_active, next_active = _inputs(spatial)
    with torch.no_grad():
        out = scripted(history, history_active, next_active)
    expected = history[-1] * history_active[-1] * next_active
    assert torch.equal(out, expected)


def test_the_prediction_scales_with_the_pressure_unit():
    """Normalisation happens inside: pressures 1000 times larger give a prediction 1000
    times larger (a network fed raw Pa would not)."""
    module = _randomised(2)
    history, history_active, next_active = _inputs((12, 10))
    with torch.no_grad():
        small = module(history, history_active, next_active)
        large = module(1000 * history, history_active, next_active)
    assert torch.allclose(large, 1000 * small, rtol=1e-4, atol=1e-3 * float(large.abs().max()))
    assert not torch.allclose(small, history[-1] * history_active[-1] * next_active)


def test_the_exported_file_carries_mpmnet_json(tmp_path):
    validation = {"relative_l2": {"interface": {"model": float("nan")}}}  # field never seen
    meta = model.metadata(3, ["fluid_pressure", "ghost_pressure", "interface"], T,
                          ["run_a", "run_b"], validation)
    path = tmp_path / "m.pt"
    model.export(model.build(3), path, meta)
    extra = {"mpmnet.json": ""}
    torch.jit.load(str(path), _extra_files=extra)
    strict = json.loads(extra["mpmnet.json"], parse_constant=lambda c: pytest.fail(c))
    assert strict["validation"]["relative_l2"]["interface"]["model"] is None
    loaded, read = model.load(path)
    assert read["format"] == "iqmpm-mpmnet" and read["format_version"] == 1
    assert read["dim"] == 3 and read["sequence_length"] == T
    assert read["trained_on"] == ["run_a", "run_b"]
    assert read["normalisation"] == model.NORMALISATION
    history, history_active, next_active = _inputs((5, 6, 7))
    with torch.no_grad():
        assert loaded(history, history_active, next_active).shape == (3, 5, 6, 7)
