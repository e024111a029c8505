"""The convolution back-end (vtcore.contact.fft): exact against a direct sum, the layer's kernel
truncation chosen automatically and reported, the padded reference and the float32 path."""

from __future__ import annotations

import numpy as np
import pytest

from vtcore.contact import ContactGrid, SoftLayer, make_object, placement_pose, press
from vtcore.contact.elastic import compliance_operator, solve_pk
from vtcore.contact.fft import Convolver, kernel_reach
from vtcore.errors import InputError
from vtcore.layout import Layout, hexagon_flat


def _direct(kernel_wrap, p):
    """u[i, j] = sum_ab K[i - a, j - b] p[a, b], the kernel read in wrap order: a plain loop."""
    mx, my = p.shape
    lx, ly = kernel_wrap.shape
    u = np.zeros((mx, my))
    for a in range(mx):
        for b in range(my):
            if p[a, b]:
                ii = (np.arange(mx)[:, None] - a) % lx
                jj = (np.arange(my)[None, :] - b) % ly
                u += kernel_wrap[ii, jj] * p[a, b]
    return u


def _decaying_kernel(mx, my, scale):
    ox = np.fft.fftfreq(2 * mx, 1 / (2 * mx))
    oy = np.fft.fftfreq(2 * my, 1 / (2 * my))
    r = np.hypot(*np.meshgrid(ox, oy, indexing="ij"))
    return np.exp(-r / scale) * (1 + 0.3 * np.cos(r))


@pytest.mark.parametrize("shape", [(7, 5), (16, 16), (13, 24)])
def test_exact_convolver_equals_the_direct_linear_convolution(shape):
    rng = np.random.default_rng(1)
    k = rng.normal(size=(2 * shape[0], 2 * shape[1]))  # no decay: nothing may be dropped
    p = rng.random(shape)
    conv = Convolver(k, shape, truncation=1e-3)
    assert conv.padded and conv.truncation == 0.0
    assert all(f >= 2 * m - 1 for f, m in zip(conv.fft_shape, shape))
    np.testing.assert_allclose(conv(p), _direct(k, p), rtol=1e-12, atol=1e-12 * np.abs(k).sum())
    np.testing.assert_allclose(conv(2 * p), 2 * _direct(k, p), rtol=1e-12, atol=1e-12 * np.abs(k).sum())


def test_truncated_convolver_drops_only_what_it_reports():
    shape = (40, 30)
    k = _decaying_kernel(*shape, scale=1.5)
    r, dropped = kernel_reach(k, shape, 1e-4)
    conv = Convolver(k, shape, truncation=1e-4)
    assert not conv.padded and conv.reach == r < 30 and 0 < conv.truncation == dropped <= 1e-4
    assert conv.fft_shape[0] < 2 * shape[0] - 1
    # equal to the direct convolution with the kernel cut at the reach ...
    ox = np.abs(np.fft.fftfreq(2 * shape[0], 1 / (2 * shape[0])))
    oy = np.abs(np.fft.fftfreq(2 * shape[1], 1 / (2 * shape[1])))
    cut = np.where(np.maximum.outer(ox, oy) <= r, k, 0.0)
    p = np.random.default_rng(2).random(shape)
    np.testing.assert_allclose(conv(p), _direct(cut, p), rtol=1e-10, atol=1e-12)
    # ... and within the dropped fraction of the full one
    full = _direct(k, p)
    assert np.abs(conv(p) - full).max() <= dropped * np.abs(k).max() * p.sum()


def test_halfspace_keeps_full_padding_and_a_decaying_layer_does_not():
    lay = SoftLayer(thickness=1e-3)
    hs = compliance_operator((64, 64), 0.5e-3, 0.5e-3, lay, "halfspace")
    assert hs.padded and hs.truncation == 0.0  # 1/r never falls to 1e-5 of its peak on the grid
    fl = compliance_operator((64, 64), 0.5e-3, 0.5e-3, lay, "finite_layer", truncation=1e-5)
    assert not fl.padded and 0 < fl.truncation <= 1e-5 and fl.fft_shape[0] < 127
    ref = compliance_operator((64, 64), 0.5e-3, 0.5e-3, lay, "finite_layer")  # the default: exact
    assert ref.padded and ref.fft_shape == (128, 128)
    with pytest.raises(InputError, match="truncation"):
        compliance_operator((8, 8), 1e-3, 1e-3, lay, "finite_layer", truncation=-1)


def _hertz_problem(n=96, dx=0.25e-3, R=0.03):
    x = (np.arange(n) - n / 2 + 0.5) * dx
    X, Y = np.meshgrid(x, x, indexing="ij")
    return R - np.sqrt(R**2 - X**2 - Y**2), dx


def test_float32_iterations_finish_in_double_precision_against_hertz():
    lay = SoftLayer()
    gap, dx = _hertz_problem()
    op = compliance_operator(gap.shape, dx, dx, lay, "halfspace", truncation=0)
    op32 = compliance_operator(gap.shape, dx, dx, lay, "halfspace", truncation=0, dtype=np.float32)
    ref = solve_pk(gap, op, dx * dx, force=1.0)
    sol = solve_pk(gap, op, dx * dx, force=1.0, conv32=op32)
    assert sol.converged and 0 < sol.iterations_float32 < sol.iterations
    assert np.linalg.norm(sol.pressure - ref.pressure) <= 1e-6 * np.linalg.norm(ref.pressure)
    assert sol.pressure.dtype == np.float64 and sol.displacement.dtype == np.float64
    a = (3 * 1.0 * 0.03 / (4 * lay.e_star)) ** (1 / 3)
    assert sol.pressure.max() == pytest.approx(3 / (2 * np.pi * a * a), rel=0.02)


@pytest.mark.parametrize("base, truncation, bound", [("bonded", None, 1e-6), ("frictionless", 1e-6, 2e-5)])
def test_truncated_layer_press_matches_the_padded_reference(base, truncation, bound):
    """A sphere through a 1 mm layer on a wide grid: the press drops the kernel's tail (by default
    below the solver tolerance times its peak, ~14 thicknesses out), reports it, and gives the
    padded solve's pressures; the float32 iterations too."""
    flat, mod = hexagon_flat()
    layout = Layout(np.column_stack([flat, np.zeros(len(flat))]), np.tile([0, 0, 1.0], (len(flat), 1)),
                    np.arange(len(flat)), mod, flat=flat)
    m = make_object("sphere")
    lay = SoftLayer(thickness=1e-3, extent=0.04, base=base)
    pose = placement_pose(m, top=1e-3, gap=1e-3)
    kw = dict(force=2.0, spread=False, grid=ContactGrid(spacing=0.25e-3))
    ref = press(layout, m, pose, lay, truncation=0, **kw)
    cut = press(layout, m, pose, lay, truncation=truncation, **kw)
    f32 = press(layout, m, pose, lay, truncation=truncation, precision="float32", **kw)
    assert ref.kernel_truncation == 0.0 and 0 < cut.kernel_truncation <= (truncation or 1e-7)
    scale = np.linalg.norm(ref.field.pressure)
    assert np.linalg.norm(cut.field.pressure - ref.field.pressure) <= bound * scale
    assert np.linalg.norm(f32.field.pressure - cut.field.pressure) <= 1e-5 * scale
    assert cut.indentation == pytest.approx(ref.indentation, rel=1e-5)
    assert f32.converged and f32.force == pytest.approx(2.0, rel=1e-9)
    with pytest.raises(InputError, match="precision"):
        press(layout, m, pose, lay, precision="float16", **kw)

