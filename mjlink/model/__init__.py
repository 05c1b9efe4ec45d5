"""The description: mechanism files read once into typed, validated objects.

:mod:`.names` (valid names, MuJoCo element names), :mod:`.limits`, :mod:`.reader` (TOML with
one-line errors), :mod:`.jet` (exact derivatives), :mod:`.blocks` (the building blocks and
their behaviour), :mod:`.mechanism` (the file format), :mod:`.topology` (pairs and the
spanning tree), :mod:`.catalogue` (registered names and paths).
"""
