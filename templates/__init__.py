"""Jinja templates of skelarm-sym (layout only), shipped inside the wheel as skelarm_sym.templates."""
