"""The convolution back-end of the contact solve: a linear convolution with a fixed kernel by real FFTs.

Every displacement and spreading in :mod:`vtcore.contact.elastic` goes through :class:`Convolver`;
swapping the FFT library means changing this module only. It uses ``scipy.fft`` (pocketfft):

* real transforms (``rfft2`` / ``irfft2``): half the work and memory of complex ones;
* sizes from ``scipy.fft.next_fast_len`` (products of 2, 3, 5, 7, 11) at least the size a linear
  (non-wrapping) convolution needs, rather than exactly 2 m;
* the kernel's spectrum computed once per grid and kept (the callers cache the Convolver);
* one zero-padded input buffer kept between calls: a call writes the pressure into its corner, and
  the spectrum is multiplied in place, so an iteration allocates only what pocketfft returns;
* ``workers``: all the cores the process may use, on transforms large enough to gain from threads.

pyFFTW (planned FFTW transforms, in-place) was measured against this on the same solves (the
numbers are in docs/contact.md): it did not earn a place as a dependency.

Padding. A kernel given on the full (2 mx, 2 my) offset grid needs a transform of at least
``2 m - 1`` per axis for a linear convolution. Where the kernel decays within the domain (a layer
on a rigid base: its compliance falls off within a few thicknesses), offsets beyond a reach ``r``
can be dropped and the transform shrinks to ``m + r``: :func:`kernel_reach` picks the smallest
``r`` beyond which no kernel value exceeds ``truncation`` times the kernel's peak (a pointwise
criterion: the tabulated layer kernel keeps a numerical floor of ~1e-8 of its peak out to 40 h,
which a mass criterion would count over thousands of cells). The exact (padded) operator is
``truncation = 0``; the end-to-end effect on solved pressures is tested and benchmarked.
"""

from __future__ import annotations

import os

import numpy as np

#: transforms with fewer points than this run on one thread: waking a pool costs more than it saves
THREADED_POINTS = 128 * 128


def one_blas_thread():
    """A context in which numpy's and scipy's BLAS run on one thread, for values that are cached.

    A BLAS product's last bits depend on its thread count, and a cached value outlives the call
    that computed it: the finite layer's Hankel tables computed by a direct ``press`` (all cores)
    and then reused inside a scene run (one BLAS thread, ``vtcore.scene.runner``) gave that run
    other bytes than a fresh process (up to 2e-10 Pa: the sweep benchmark's serial loop after the
    contact benchmark, 0 of 4 points identical to dask). Every cache of the contact stage fills
    itself under this context, so its values are the same whoever asks first.
    """
    import scipy.linalg  # noqa: F401  (loads scipy's own OpenBLAS, so it is limited too)
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


def workers() -> int:
    """Cores this process may use (its CPU affinity), for the FFT threads."""
    try:
        return max(len(os.sched_getaffinity(0)), 1)
    except AttributeError:  # pragma: no cover - not on Linux
        return max(os.cpu_count() or 1, 1)


def _offsets_1d(n2):
    """Offsets (cells) of a wrap-ordered axis of length ``n2`` = 2 m: 0..m-1, then -m..-1."""
    return np.fft.fftfreq(n2, 1.0 / n2).astype(np.int64)


def kernel_reach(kernel_wrap, shape, truncation):
    """Smallest reach ``r`` (cells, Chebyshev distance) beyond which every kernel value is at most
    ``truncation`` times the kernel's peak.

    kernel_wrap : (2 mx, 2 my) in FFT wrap order. shape : (mx, my), the grid of the convolved field.
    truncation : >= 0, relative to ``max |K|``. Returns ``(r, dropped)``: ``r`` in cells
    (``max(shape) - 1`` keeps every offset a linear convolution on the grid can use) and the largest
    dropped value relative to the peak (0 when nothing is dropped).
    """
    mx, my = shape
    full = max(mx, my) - 1
    if truncation <= 0:
        return full, 0.0
    ox, oy = _offsets_1d(kernel_wrap.shape[0]), _offsets_1d(kernel_wrap.shape[1])
    use_x, use_y = np.abs(ox) <= mx - 1, np.abs(oy) <= my - 1  # offsets a grid of mx x my can see
    a = np.abs(kernel_wrap[np.ix_(use_x, use_y)])
    peak = a.max()
    if not peak > 0:
        return full, 0.0
    ring = np.maximum.outer(np.abs(ox[use_x]), np.abs(oy[use_y]))
    ring_max = np.zeros(full + 1)
    np.maximum.at(ring_max, ring.ravel(), a.ravel())
    beyond = np.append(np.maximum.accumulate(ring_max[::-1])[::-1][1:], 0.0) / peak  # max over rings > r
    r = int(np.argmax(beyond <= truncation))  # the last ring always qualifies (nothing beyond it)
    return r, float(beyond[r])


class Convolver:
    """``u = K * p``: linear convolution with a fixed kernel on an (mx, my) grid.

    kernel_wrap : (2 mx, 2 my) float, the kernel at every offset in FFT wrap order (offset 0 at
    [0, 0]). shape : (mx, my). truncation : relative kernel value that may be dropped to shrink the
    transform (see the module's docstring; 0: exact). dtype : float64, or float32 for a faster,
    less precise operator (the spectrum is rounded once, the transforms run in single precision).

    Attributes: ``fft_shape`` (2,) the transform size, ``reach`` (cells kept), ``truncation`` (the
    largest dropped kernel value relative to its peak), ``padded`` (True when no offset was dropped).
    """

    def __init__(self, kernel_wrap, shape, *, truncation: float = 0.0, dtype=np.float64):
        import scipy.fft as sfft  # pocketfft with real-input plans: ~2x numpy's on small grids

        self._fft = sfft
        self.shape = tuple(int(s) for s in shape)
        self.dtype = np.dtype(dtype)
        mx, my = self.shape
        k = np.asarray(kernel_wrap, float)
        r, dropped = kernel_reach(k, self.shape, truncation)
        rx, ry = min(r, mx - 1), min(r, my - 1)
        full = (sfft.next_fast_len(2 * mx - 1, real=True), sfft.next_fast_len(2 * my - 1, real=True))
        short = (sfft.next_fast_len(mx + rx, real=True), sfft.next_fast_len(my + ry, real=True))
        if short[0] * short[1] >= full[0] * full[1]:  # nothing to gain: keep the exact operator
            short, rx, ry, dropped = full, mx - 1, my - 1, 0.0
        self.fft_shape = short
        self.reach = max(rx, ry)
        self.truncation = dropped
        self.padded = dropped == 0.0
        lx, ly = short
        emb = np.zeros(short)
        ox, oy = _offsets_1d(k.shape[0]), _offsets_1d(k.shape[1])
        sx, sy = np.abs(ox) <= rx, np.abs(oy) <= ry
        # offsets kept: 0..r at the start of each axis, -r..-1 at its end (wrap order of length l)
        emb[np.ix_(np.mod(ox[sx], lx), np.mod(oy[sy], ly))] = k[np.ix_(sx, sy)]
        self.workers = workers() if lx * ly >= THREADED_POINTS else 1
        ctype = np.complex64 if self.dtype == np.float32 else np.complex128
        self.khat = sfft.rfft2(emb, workers=self.workers).astype(ctype)
        self._buf = np.zeros(short, self.dtype)

    def __call__(self, p):
        """(mx, my) ``K * p`` in the operator's dtype; p (mx, my)."""
        mx, my = self.shape
        f = self._fft
        self._buf[:mx, :my] = p
        spec = f.rfft2(self._buf, workers=self.workers)
        spec *= self.khat
        return f.irfft2(spec, s=self.fft_shape, workers=self.workers, overwrite_x=True)[:mx, :my]
