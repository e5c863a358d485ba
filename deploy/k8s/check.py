#!/usr/bin/env python3
"""Schema check of the Kubernetes manifests in this folder, without a cluster.

`kubectl apply --dry-run=client` still needs an API server to discover the resource
types, so instead every field is checked against the models of the official Python
client (`kubernetes`, generated from the Kubernetes OpenAPI spec): an unknown field, a
value of the wrong type (by a walk over the models' field types) or a missing required
field (by the models' own validation) is an error. Then the wavetrace
parts: an Indexed Job whose `--tile $JOB_COMPLETION_INDEX/N` has N = completions.
Usage: check.py FILE.yaml... (deploy/k8s/check.sh installs the client and runs it).
Exit 1 on any error.
"""
import re
import sys

import kubernetes.client as k8s
import yaml

SCALARS = {"str": str, "int": int, "bool": bool, "float": (int, float)}


def check(value, typ, path, errors):
    """Appends to `errors` every way `value` does not fit the OpenAPI type `typ`."""
    typ = typ.strip()
    if typ[:5].lower() == "list[":
        if not isinstance(value, list):
            return errors.append(f"{path}: expected a list")
        for i, v in enumerate(value):
            check(v, typ[5:-1], f"{path}[{i}]", errors)
    elif typ[:5].lower() in ("dict(", "dict["):
        if not isinstance(value, dict):
            return errors.append(f"{path}: expected a map")
        inner = typ[5:-1].split(",", 1)[1]
        for key, v in value.items():
            check(v, inner, f"{path}.{key}", errors)
    elif typ in SCALARS:
        if not isinstance(value, SCALARS[typ]) or (typ == "int" and isinstance(value, bool)):
            errors.append(f"{path}: expected {typ}, got {value!r}")
    elif typ.lower() in ("object", "datetime", "any"):
        pass
    else:
        model = getattr(k8s, typ)
        if not isinstance(value, dict):
            return errors.append(f"{path}: expected a {typ} object")
        by_json = {j: a for a, j in model.attribute_map.items()}
        for key, v in value.items():
            if key not in by_json:
                errors.append(f"{path}.{key}: no such field in {typ}")
            else:
                check(v, model.openapi_types[by_json[key]], f"{path}.{key}", errors)


def main(paths):
    errors = []
    for path in paths:
        with open(path, encoding="utf-8") as f:
            docs = [d for d in yaml.safe_load_all(f) if d]
        for doc in docs:
            if (doc.get("apiVersion"), doc.get("kind")) != ("batch/v1", "Job"):
                errors.append(f"{path}: expected apiVersion batch/v1, kind Job")
                continue
            before = len(errors)
            check(doc, "V1Job", path, errors)
            if len(errors) == before:
                try:
                    # The client's models (pydantic) also refuse missing required fields.
                    k8s.V1Job.model_validate(doc)
                except ValueError as e:
                    errors.append(f"{path}: {e}")
            spec = doc.get("spec", {})
            text = yaml.safe_dump(spec)
            tile = re.search(r"--tile \"?\$JOB_COMPLETION_INDEX/(\d+)", text)
            if spec.get("completionMode") == "Indexed":
                if not tile:
                    errors.append(f"{path}: an Indexed Job without --tile $JOB_COMPLETION_INDEX/N")
                elif int(tile.group(1)) != spec.get("completions"):
                    errors.append(f"{path}: --tile .../{tile.group(1)} but completions {spec.get('completions')}")
            elif "wavetrace merge" not in text:
                errors.append(f"{path}: neither an Indexed render Job nor a merge")
    for e in errors:
        print(e)
    if not errors:
        print(f"k8s manifests ok: {', '.join(paths)} (kubernetes client {k8s.__version__} models)")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
