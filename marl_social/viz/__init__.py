"""Visualization: live frames of a world, animations and the paper-style episode figure.

* `style`: colours, sizes and drawing constants; `RenderConfig`, the env's render settings.
* `road`: the static map (road, lane markings, crosswalk stripes, houses) on an Axes.
* `text`: name labels and the time stamp as pre-rendered sprites pasted with numpy.
* `frames`: `Renderer`, (H, W, 3) uint8 RGB frames of a `World` (and the "human" window).
* `figures`: `plot_episode`, the figure of Figs. 3-6 of Sun et al. 2019.
* `overlay`: `caption_frames`, the legend and the robot's belief bar under each demo frame.
* `animation`: `write_animation`, frames as an animated GIF.

Nothing is imported here, so `marl_social.viz.style` loads without matplotlib.
"""
