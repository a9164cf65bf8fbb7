"""The dualsys learning core, grouped by the paper's parts; each package may import only those below it.

    config          one typed config per run, its profiles (``default``, ``paper``) — read by every package
    task_levels     NicoGrasp's task levels as data (read by config and by the env)
    envs/           the environments: NicoGrasp (the paper's task, Sec. 4.1) and any gymnasium task
    modelfree/      the model-free control system (Sec. 2.1): encoder f_ω, critic-autoencoder, actor, replay
    dual/           the dual system (Sec. 2.2-2.4): ITM, local world models, learning progress,
                    meta-controller, planning, imagination, the dual-system agents
    runs/           one training run: trainer, run directory, bookkeeping, metrics, the method registry,
                    loading a trained policy
    experiments/    grids of runs: spec, cells, local and Ray runners, report
    deploy/         ONNX export, the Robot protocol, the grasp-trial evaluator

The import direction is a DAG: task_levels → config → envs → modelfree → dual → runs →
{experiments, deploy}; nothing imports upward (tests/test_layout.py checks it). `core` imports none of
the other dualsys packages (docs/layout.md: the floors, and why each module sits where it does).
"""
