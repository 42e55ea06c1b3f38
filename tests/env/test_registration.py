"""A fresh process makes careful's environment with Gymnasium's module prefix, importing nothing of careful first."""

import subprocess
import sys


def test_gymnasium_make_with_the_module_prefix_in_a_fresh_process():
    code = (
        "import gymnasium as gym\n"
        "env = gym.make('irl_core.worlds.env:careful/Careful-v0', world='cliffwalking')\n"
        "obs, info = env.reset(seed=0)\n"
        "print(obs, env.spec.id, env.action_space)\n"
    )
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert run.stdout.split() == ["36", "careful/Careful-v0", "Discrete(56)"]
