"""Studies that regenerate the documentation's tables and figures from the shipped
scenarios: ``reproduce`` (the paper's tables), ``noise_sweep`` (Fig. 14) and
``methods_table`` (every method side by side). Each is a ``python -m`` module that takes
explicit output paths, so it runs from an installed wheel as well as from a checkout.
"""
