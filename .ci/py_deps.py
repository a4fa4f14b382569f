"""Prints the third-party requirements of the Python packages named on the command line
(their `project.dependencies` and `test` extras, from each folder's pyproject.toml), one
per line, leaving out trimorph itself. CI installs them into the test venv in the
background while the Rust code compiles; test.sh then finds them installed."""

import sys
import tomllib

seen = []
for folder in sys.argv[1:]:
    with open(f"{folder}/pyproject.toml", "rb") as f:
        project = tomllib.load(f)["project"]
    reqs = project.get("dependencies", []) + project.get("optional-dependencies", {}).get("test", [])
    for r in reqs:
        name = r.split(">")[0].split("<")[0].split("=")[0].split("[")[0].strip()
        if name.lower() != "trimorph" and r not in seen:
            seen.append(r)
print("\n".join(seen))
