"""The part a workshop makes: outlines, bores, grooves, DXF/SVG/STL files and drawing sheets."""
