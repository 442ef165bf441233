"""The independent re-check of a design, and its torque model as one differentiable Function."""
