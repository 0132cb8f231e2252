"""equations layer (see DESIGN.md)."""
