"""Control design on top of the simulation stage: linearised plants and the arm's modes along
a manoeuvre (docs/control.md)."""
