"""The names of the files in a run folder (written by `writers`, read by `reading`, shown
by `report_html`)."""

RESOLVED_NAME = "scenario.resolved.toml"
RESULTS_CSV = "results.csv"
CHANNELS_CSV = "channels.csv"
RESULTS_NC = "results.nc"
RESULTS_MAT = "results.mat"
ANIMATION_GIF = "animation.gif"
REPORT_NAME = "report.html"
