"""Old path of bridge/tools/parquet_equals_csv.py: runs it after a DeprecationWarning."""

from platoon._moved import alias

alias(__name__, run="tools/parquet_equals_csv.py")
