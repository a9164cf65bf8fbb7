"""dualsys sim2real: paired sim/real image sets and the encoder alignment of Section 4.2 (Fig. 13).

Plain functions with keyword arguments for the CLI and the job service: ``generate_pairs(n=, out=, seed=,
camera_shift=)``, ``load_pairs(folder)``, ``align_encoder(policy_path=, pairs_dir=, out_dir=, epochs=,
batch_size=)`` (see docs/deployment.md). The real-camera stand-in itself is ``core.envs.CameraShift``.
"""

from sim2real.alignment import AlignmentError, AlignmentReport, EpochRecord, align_encoder, transfer_loss
from sim2real.pair_dataset import PairDataError, PairedImages, PairFolderNotFound, load_pairs, read_image
from sim2real.pair_generation import PairsReport, generate_pairs, read_camera_shift

__all__ = [
    "AlignmentError",
    "AlignmentReport",
    "EpochRecord",
    "PairDataError",
    "PairFolderNotFound",
    "PairedImages",
    "PairsReport",
    "align_encoder",
    "generate_pairs",
    "load_pairs",
    "read_camera_shift",
    "read_image",
    "transfer_loss",
]
