"""Mechanisms: one folder each (its model, its paper physics, its starts and baselines, its
target kinds), registered by name (:func:`cadcam.mechanisms.base.register`).

Importing this package imports every mechanism folder beside it, which registers it: a new
mechanism is a new folder, and nothing outside it names it.
"""
import importlib
import pkgutil

for _module in pkgutil.iter_modules(__path__):
    if _module.ispkg:
        importlib.import_module(f"{__name__}.{_module.name}")
