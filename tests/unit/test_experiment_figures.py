"""The figures of `flexlink compare` and `flexlink fit` (experiment/figures.py): what their
axes say is what they draw."""

from __future__ import annotations

import numpy as np

from flexlink.experiment.figures import FigureData, overlay_figure, spectra_figure


def _data() -> FigureData:
    t = np.arange(0.0, 4.0, 1e-3)
    measured = 0.002 * np.sin(2 * np.pi * 5.0 * t)  # m: 2 mm at 5 Hz
    return FigureData(names=["tip"], units={"tip": "m"}, time=t, measured={"tip": measured},
                      simulated={"tip": 0.5 * measured}, free_start=0.0,
                      frequencies={"tip": (5.0, 5.0)})


def test_the_spectra_are_amplitudes_in_the_signal_s_unit() -> None:
    """The spectra were |FFT| of the windowed samples, a number without unit that grows with
    the record's length; a sinusoid now peaks at its amplitude, in the axis' unit."""
    ax = spectra_figure(_data()).axes[0]
    assert ax.get_ylabel() == "tip\namplitude [mm]"
    peaks = [line.get_ydata().max() for line in ax.get_lines() if line.get_label() in
             ("measured", "simulated")]
    np.testing.assert_allclose(peaks, [2.0, 1.0], rtol=0.02)


def test_the_legend_stands_above_the_panels_not_on_the_data() -> None:
    """The legend sat in each panel's upper right corner, over the traces there."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    for figure in (overlay_figure(_data()), spectra_figure(_data())):
        renderer = FigureCanvasAgg(figure).get_renderer()
        top = figure.axes[0]
        legend = top.get_legend()
        assert legend is not None
        assert all(ax.get_legend() is None for ax in figure.axes[1:])
        assert legend.get_window_extent(renderer).y0 >= top.get_window_extent(renderer).y1 - 1
