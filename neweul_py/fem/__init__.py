"""fem layer (see DESIGN.md)."""
