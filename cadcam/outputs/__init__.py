"""The files of a run: result tables, figures, and the drawing processes that make them."""
