"""Test-only "person" for ``expert=mouse``: moves the real mouse source with synthetic pygame events.

Each step it looks at the agent, and when the robot hands over it presses on the agent, then drags
the cursor along the aperture task's scripted expert (noise-free); when the robot takes back control
it releases. With ``takes_over=true`` (HG-DAgger) it decides itself, as the scripted expert judges
the robot's proposed command: it presses on the agent to take over and releases to hand back.
Everything after the events (grab, offsets, clipping, labels, drawing) is the real
:class:`~dpiil_rl.experts.mouse.MouseLeaderExpert`. Select it like a plug-in:
``expert=mouse expert._target_=tests.mocks.scripted_person.ScriptedMousePerson expert.realtime=false``.
"""

from __future__ import annotations

import torch
from tensordict import TensorDictBase

from dpiil_rl.experts.mouse import MouseLeaderExpert
from dpiil_rl.experts.scripted import build_scripted_policy


class ScriptedMousePerson(MouseLeaderExpert):
    def __init__(self, env, quit_after_steps: int | None = None, takes_over: bool = False, **kwargs) -> None:  # type: ignore[no-untyped-def]
        super().__init__(env, **kwargs)
        self.quit_after_steps = quit_after_steps  # the person closes the window after this many steps
        self.takes_over = bool(takes_over)  # HG-DAgger: the person judges the robot and grabs it
        self.steps = 0
        self.script = build_scripted_policy(env)
        self.script.noise_floor, self.script.noise_gain = 0.0, 0.0
        self.rng = torch.Generator().manual_seed(0)
        self.grabs = 0

    def observe(self, tensordict: TensorDictBase) -> None:
        pg = self._pygame
        self.steps += 1
        if self.quit_after_steps is not None and self.steps >= self.quit_after_steps:
            pg.event.post(pg.event.Event(pg.QUIT))
        agent = tensordict.get(self.observation_key).reshape(-1, 2)[:1]
        mode = tensordict.get("expert_mode", None)
        wanted = bool(mode.reshape(-1)[0]) if mode is not None else True
        proposed = tensordict.get("policy_action", None)  # absent in demonstrations: the person drives them
        if self.takes_over and proposed is not None:
            held = torch.tensor([[self.handover.moving]])
            wanted = bool(self.script.wants_control(agent, proposed.reshape(-1, 2)[:1], held).reshape(-1)[0])
        here = self.to_px(*agent[0].tolist())
        if wanted:
            if not self.handover.moving:
                pg.event.post(pg.event.Event(pg.MOUSEBUTTONDOWN, pos=here, button=1))
                self.grabs += 1
            step = self.script(agent, self.rng)[0].tolist()
            target = self.to_px(agent[0, 0].item() + step[0], agent[0, 1].item() + step[1])
            pg.event.post(pg.event.Event(pg.MOUSEMOTION, pos=target, rel=(0, 0), buttons=(1, 0, 0)))
        elif self.handover.moving:
            pg.event.post(pg.event.Event(pg.MOUSEBUTTONUP, pos=here, button=1))
        super().observe(tensordict)
