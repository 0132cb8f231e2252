"""codegen layer (see DESIGN.md)."""
