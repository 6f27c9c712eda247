#pragma once
// mucosa dataset plan / run / verify / slurm: a dataset as a plan folder whose
// every frame is a pure function of (plan, frame index), so that any sharding
// over any number of machines gives the same bytes (docs/datasets.md,
// "Datasets on a cluster").
//
// The plan folder DIR:
//   DIR/plan.json                 what to render (scene, settings, frames, content hash)
//   DIR/frames/frame_NNNNNN.png   the frames and their ground truth (dataset::outputFiles)
//   DIR/frames/frame_NNNNNN.sha256  each frame's files' SHA-256, `sha256sum -c` format,
//                                 written last: a frame is done when this exists
//   DIR/frames.json               the dataset manifest, written by `verify`
//   DIR/slurm/                    `mucosa dataset slurm`: the sbatch script and logs
#include <CLI/CLI.hpp>

#include "commands.hpp"

namespace mucosa::cli {

// mucosa dataset slurm DIR --shards K [--partition P] [--time T] [--gres G] [--submit]
// (cmd_dataset_slurm.cpp)
void addSlurmCommand(CLI::App& dataset, Global& g);

}  // namespace mucosa::cli
