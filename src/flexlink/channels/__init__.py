"""Output channels: one record per channel (`Channel`, with its `ChannelKind` and unit), and
the channels of each model computed from a solved run."""

from .record import SENSOR_UNITS, Channel, ChannelKind, ChannelTable, Unit, kind_summary

__all__ = ["SENSOR_UNITS", "Channel", "ChannelKind", "ChannelTable", "Unit", "kind_summary"]
