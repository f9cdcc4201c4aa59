"""The study: ground truth, error metrics, the comparison matrix and runner, report and tune.

groundtruth.py (item-buffer visible sets, ray-cast cross-check), metrics.py (false negatives,
false-negative pixels, tightness, Pareto front), matrix.py (selection -> RunSpecs), runner.py
(parallel, resumable scheduling) of tasks.py (one run's work), report.py (self-contained
HTML), costmodel.py (counters -> ms), tune.py (automatic configuration), thesis.py (the
thesis's reference numbers), engine.py (the study's access to worlds, partitions, cullers and the renderer).
"""
