"""Plain-text tables, JSON-safe values and progress lines for commands and reports."""
