"""The ``pydrake_system`` directive of Drake's own docs: a system's ports,
given as YAML in its docstring, shown as a block of its input and output ports
(Drake draws a box; a listing says the same)."""

from __future__ import annotations

import yaml
from docutils import nodes
from docutils.parsers.rst import Directive


class PydrakeSystem(Directive):
    has_content = True

    def run(self):
        spec = yaml.safe_load("\n".join(self.content)) or {}
        name = spec.get("name", "system")
        inputs = spec.get("input_ports", []) or []
        outputs = spec.get("output_ports", []) or []
        width = max([len(str(p)) for p in inputs] + [0])
        rows = max(len(inputs), len(outputs), 1)
        lines = [f"{'':{width}}    +-- {name} --+"]
        for i in range(rows):
            left = f"{inputs[i]} -->" if i < len(inputs) else ""
            right = f"--> {outputs[i]}" if i < len(outputs) else ""
            lines.append(f"{left:>{width + 4}} |{'':{len(name) + 6}}| {right}")
        lines.append(f"{'':{width}}    +{'-' * (len(name) + 8)}+")
        text = "\n".join(lines)
        return [nodes.literal_block(text, text, classes=["pydrake-system"])]


def setup(app):
    app.add_directive("pydrake_system", PydrakeSystem)
    return {"parallel_read_safe": True}
