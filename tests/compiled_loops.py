"""The compiled sampled loop of a LoopController on a Simulator of the test's own, for tests
that compare it with the Python loop or count its evaluations."""

from flexure.core import run_sampled_loop


def run_compiled_loop(sim, controller, design):
    """`flexure.core.run_sampled_loop` of `controller`'s state-space feedback and feedforward
    on `sim`, as `flexure.controllers.sample_loop.compiled_loop` runs it on a simulator of its
    own: t (s), position (m), force (N)."""
    feedback = controller.controller
    return run_sampled_loop(
        sim, fs=controller.fs, samples=controller.samples, reference=controller.reference,
        feedforward=controller.feedforward,
        controller=(feedback.A, feedback.B, feedback.C, feedback.D),
        loop_inputs=[pair.input_index for pair in design.pairs],
        loop_outputs=[pair.output_index for pair in design.pairs])
