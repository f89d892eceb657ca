"""C code generation: Jinja environment, C literal helpers, render(qmodel, prefix) -> {filename: text}."""
