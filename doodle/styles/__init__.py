"""Brush styles as data (TOML/JSON): built-ins ink, pen, pencil, charcoal, marker, sketchy, blueprint."""

from .render import styled_path_data
from .style import FilterStyle, HiddenStyle, LineStyle, Style, builtin_names, load_style, style_from_dict

__all__ = ["FilterStyle", "HiddenStyle", "LineStyle", "Style", "builtin_names", "load_style", "style_from_dict",
           "styled_path_data"]
