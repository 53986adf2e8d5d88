"""Checks that a Parquet output of `platoon run` holds exactly the rows of the CSV of the same
run (same columns, same values; NaN equals NaN), as pandas or polars users would read them:

    bridge/.venv/bin/python bridge/tools/parquet_equals_csv.py run-parquet/trajectories.parquet run-csv/trajectories.csv

Exit 0 when equal, 1 with the first difference otherwise.
"""

import csv
import math
import sys

import pyarrow as pa
import pyarrow.parquet as pq


def convert(value: str, kind: pa.DataType):
    if value == "":
        return None
    if pa.types.is_floating(kind):
        return float(value)
    if pa.types.is_integer(kind):
        return int(value)
    if pa.types.is_boolean(kind):
        return value == "true"
    return value


def same(a, b) -> bool:
    if isinstance(a, float) and isinstance(b, float):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


def main() -> int:
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    parquet_path, csv_path = sys.argv[1], sys.argv[2]
    table = pq.read_table(parquet_path)
    with open(csv_path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader)
        if header != table.schema.names:
            print(f"columns differ: {header} vs {table.schema.names}")
            return 1
        kinds = [table.schema.field(n).type for n in header]
        rows = table.to_pylist()
        n = 0
        for i, line in enumerate(reader):
            if i >= len(rows):
                print(f"the CSV has more rows than the {len(rows)} of the Parquet file")
                return 1
            for name, kind, value in zip(header, kinds, line):
                expected = convert(value, kind)
                if not same(rows[i][name], expected):
                    print(f"row {i}, {name}: Parquet {rows[i][name]!r}, CSV {expected!r}")
                    return 1
            n += 1
        if n != len(rows):
            print(f"the Parquet file has {len(rows)} rows, the CSV {n}")
            return 1
    print(f"{parquet_path}: {n} rows equal to {csv_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
