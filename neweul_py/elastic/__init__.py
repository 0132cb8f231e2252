"""elastic layer (see DESIGN.md)."""
