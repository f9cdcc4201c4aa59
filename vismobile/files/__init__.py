"""Reading and writing files: atomic writes, the OBJ reader, the other mesh formats, and the loader
that dispatches a world file on its type (loader.py, above world/ and terrain/)."""
