"""Export a design's model or a problem's NLP as code (C, a shared library, .casadi) with a
manifest."""
