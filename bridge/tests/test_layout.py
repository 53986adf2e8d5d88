"""The Python payload mirrors have the Rust layout: size, alignment and every field offset, as
`wire_layout.json` records them (a Rust test checks that file against the Rust types)."""

import ctypes
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, ".."))

import platoon.wire as w  # noqa: E402

with open(os.path.join(HERE, "..", "wire_layout.json")) as f:
    LAYOUT = json.load(f)
RUST = LAYOUT["types"]


def test_the_contract_version_is_the_rust_one():
    assert w.CONTRACT_VERSION == LAYOUT["contract_version"]


def test_every_rust_type_has_a_mirror():
    assert sorted(RUST) == sorted(t.type_name() for t in w.ALL_TYPES)
    for t in w.ALL_TYPES:
        assert t.type_name() == f"platoon::v{w.CONTRACT_VERSION}::{t.__name__}"


def test_size_alignment_and_offsets_match():
    for t in w.ALL_TYPES:
        r = RUST[t.type_name()]
        assert ctypes.sizeof(t) == r["size"], t.type_name()
        assert ctypes.alignment(t) == r["align"], t.type_name()
        fields = [(name, getattr(t, name).offset) for name, _ in t._fields_]
        assert fields == [tuple(f) for f in r["fields"]], t.type_name()


def test_service_names_match_the_rust_function():
    assert w.service_name("r1", "tx") == "platoon/r1/tx"
    assert w.wake_name("r1", "injector") == "platoon/r1/wake/injector"


def test_traffic_is_a_service_that_wakes_nobody():
    assert w.service_name("r1", "traffic") == "platoon/r1/traffic"
    assert w.WAKES["traffic"] == []
    assert w.TrafficVehicle.ON_ROAD == 1


def test_inspections_are_a_service_that_wakes_nobody():
    assert w.service_name("r1", "inspections") == "platoon/r1/inspections"
    assert w.WAKES["inspections"] == []
    assert (w.Inspection.FLAGGED, w.Inspection.REFUSED, w.Inspection.DETECTOR_SHIFT) == (1, 2, 8)


def test_the_contract_docs_state_this_modules_contract_version():
    # Issue 50, item 6: both docs said PLATOON_CONTRACT_VERSION was 3 while runs set 4.
    import re

    docs = os.path.join(HERE, "..", "..", "docs")
    for doc in ("injector-contract.md", "controller-contract.md"):
        with open(os.path.join(docs, doc), encoding="utf-8") as f:
            text = f.read()
        assert re.findall(r"This page describes platoon contract v(\d+)", text) == [
            str(w.CONTRACT_VERSION)
        ], doc
        row = re.search(r"^\| `PLATOON_CONTRACT_VERSION` \|.*?\(`(\d+)`\)", text, re.M)
        assert row and int(row.group(1)) == w.CONTRACT_VERSION, doc
