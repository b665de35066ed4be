#!/usr/bin/env python3
"""Validates a JSON document against one of docs/schemas/*.schema.json (tests/json_output_test.cpp).

Usage: check_json_schema.py SCHEMA DOCUMENT. Exit 0 valid, 1 invalid (the errors on stdout),
77 when python3-jsonschema is not installed (scripts/install-deps.sh installs it)."""
import json
import sys

try:
    import jsonschema
except ImportError:
    print("SKIP: python3-jsonschema is not installed (scripts/install-deps.sh installs it)")
    sys.exit(77)

with open(sys.argv[1], encoding="utf-8") as f:
    schema = json.load(f)
with open(sys.argv[2], encoding="utf-8") as f:
    text = f.read()
try:
    doc = json.loads(text)
except json.JSONDecodeError as e:
    print(f"{sys.argv[2]}: not one JSON document: {e}\n{text[:2000]}")
    sys.exit(1)
cls = jsonschema.validators.validator_for(schema)
cls.check_schema(schema)
errors = sorted(cls(schema).iter_errors(doc), key=lambda e: list(e.path))
for e in errors[:20]:
    print(f"{sys.argv[2]}: at /{'/'.join(str(p) for p in e.path)}: {e.message[:300]}")
sys.exit(1 if errors else 0)
