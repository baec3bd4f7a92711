"""Accuracy studies: sweep scene settings, measure the error against closed forms and the cost
(``warpsph study STUDY.toml``; docs/accuracy.md, *The command*). The modules: :mod:`~warpsph.study.spec`
(study files), :mod:`~warpsph.study.metrics` (error metrics), :mod:`~warpsph.study.execute` (runs, records)
and :mod:`~warpsph.study.report` (reports). This package imports nothing heavy itself, so the command line
stays quick to start.
"""
