"""Planted-defect engines (refsim with one deliberate bug each) and the driver that shows the
harness's verdicts catch them: `python -m refsim_adapters.planted_defects [--defect NAME]
[--case NAME] [--quick]`. See `engines` (the defects) and `driver` (the jobs, the comparison, the table)."""
