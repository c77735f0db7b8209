"""
Which kept stages a new fit leaves wrong: one rule for every fit, the node's and the commands'.

A stage measured through other stages holds their frame.  ``MEASURED_THROUGH``
names, for each such stage, the stages whose replacement moves its input by
more than its own 1 sigma (measured on the physical simulator,
``sim.sensor_model``; ``test_stage_invalidation``):

* ``toolface_mark``: captured through the accelerometer's ``stand`` and the
  mount (``installation``, ``tool_axis``).  A mark captured without a mount and
  kept after ``inclino fit-level`` leaves every toolface 1.27 deg off (the
  quartz tool, the mark's own 1 sigma 0.0003 deg); kept after a new sphere
  stand of ``inclino fit-magnetometer``, 0.02 deg off (the turn of the sphere
  fit's upper-triangular frame about the tool axis, 70 sigma).
* ``magnetometer_nonlinear``: fitted through the magnetometer's own stages and
  the accelerometer's ``stand`` (whose rotation the magnetometer follows), NOT
  the mount: the stage needs roll sets, which measure the tool axis, and a
  level bench measures the same mount again, within both captures' noise
  (the MEMS tool with a cubic magnetometer: the stage's output moved by 0.07 nT
  at most, the azimuth RMS error 0.1865 -> 0.1866 deg with it kept).  Seed 002's
  ``magnetic`` stage (``inclino fit-rotation``) comes after it and moves
  nothing it sees.

``replace_stages`` puts a fit's new stages in and drops those that were
measured through a replaced one, with a note for the fit's report.
"""

from dataclasses import replace

#: For each stage measured through others: those stages, and what to do after they change.
MEASURED_THROUGH = {
    'toolface_mark': (('stand', 'installation', 'tool_axis'),
                      'capture the high-side mark again (inclino fit-toolface-mark, '
                      '~/capture_high_side_mark)'),
    'magnetometer_nonlinear': (('stand', 'magnetometer', 'magnetometer_alignment'),
                               'fit the magnetometer again (inclino fit-magnetometer)'),
}


def replace_stages(model, **stages):
    """
    Return (``model`` with ``stages`` replaced, notes on the stages dropped with them).

    A stage of ``MEASURED_THROUGH`` not itself given is dropped when one of the
    stages it was measured through changes (a new stage, or one removed);
    each note says which and what to do.
    """
    changed = {name for name, stage in stages.items() if stage != getattr(model, name)}
    dropped, notes = {}, []
    for name, (through, advice) in MEASURED_THROUGH.items():
        moved = [n for n in through if n in changed]
        if name in stages or getattr(model, name) is None or not moved:
            continue
        dropped[name] = None
        notes.append(f'{name} stage dropped: it was measured through the '
                     f'{" and ".join(moved)} stage{"s" if len(moved) > 1 else ""} this fit '
                     f'replaced; {advice}')
    return replace(model, **stages, **dropped), tuple(notes)
