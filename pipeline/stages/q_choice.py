"""The Q used downstream (Sec. 2): the best on the paper's grids, the continuous optimum of the
metric, or a value set in the config. A stage of its own, so that a change of `derivation.Q`
does not rerun the scan, and a change of a scan setting that leaves the chosen Q as it was stops
here.
"""


def run(config, inputs, memo):
    choice = config["derivation.Q"]
    Q_used = {"scan": inputs["q_scan.Q_scan_best"], "optimize": inputs["q_scan.Q_continuous_best"]}.get(choice, choice)
    return dict(Q_used=float(Q_used))
