"""Accuracy studies: sweep scene settings, measure the error against closed forms and the cost.

``warpsph study STUDY.toml`` (docs/accuracy.md). The modules: :mod:`~warpsph.study.spec` (study
files, cases), :mod:`~warpsph.study.metrics` (the error metrics), :mod:`~warpsph.study.execute`
(runs through dask.distributed, resumable records), :mod:`~warpsph.study.report` (CSV, JSON,
Markdown, plots, Pareto front). From Python::

    from warpsph.study.execute import run_studies
    from warpsph.study.report import write_reports
    from warpsph.study.spec import load_study

    for outcome in run_studies([load_study("studies/wave_column.toml")], "runs/studies"):
        write_reports(outcome)

This package imports nothing heavy itself, so the command line stays quick to start.
"""
