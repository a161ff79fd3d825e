"""What a run writes into `outputs/<name>/`: results.json, data tables, figures, the shader export
and the report. These modules only read stage results; they compute nothing that is reported.
"""
