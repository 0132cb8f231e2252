"""description layer (see DESIGN.md)."""
