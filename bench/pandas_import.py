"""The CSV import peer of bench/import_bench.sh: pandas read_csv of a log (its default C parser),
then every column written with h5py as Stend's run store writes its samples (docs/recording-format.md:
float64 datasets under /samples, chunks of 65 536, shuffle + gzip level 1 + Fletcher-32).

    /usr/bin/python3 bench/pandas_import.py LOG.csv OUT.h5     (Debian's python3-pandas, python3-h5py)
"""
import sys

import h5py
import pandas

log, out = sys.argv[1], sys.argv[2]
frame = pandas.read_csv(log)
with h5py.File(out, "w") as f:
    samples = f.create_group("samples")
    for name in frame.columns:
        column = frame[name].to_numpy("float64")
        samples.create_dataset(name, data=column, chunks=(max(1, min(len(column), 65536)),), shuffle=True,
                               compression="gzip", compression_opts=1, fletcher32=True)
