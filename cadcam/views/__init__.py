"""Views of a result: plots, workshop drawings and files, code export. No physics here."""
