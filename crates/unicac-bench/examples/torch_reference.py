"""PyTorch side of docs/performance.md (bench section): builds two small restoration networks with fixed
seeds, exports them to ONNX following docs/models.md (input `lq`, output `restored`, dynamic N/H/W,
opset 17) and times PyTorch CPU inference at 1 x 3 x 256 x 256 with the same thread count the Rust
example uses. Also checks the exported model against PyTorch in onnxruntime (max abs difference).

    python crates/unicac-bench/examples/torch_reference.py OUT_DIR [--threads 2]

then `cargo run --release -p unicac-bench --example ort_throughput -- OUT_DIR/*.onnx`.
"""
import argparse
import pathlib
import time

import numpy as np
import torch
from torch import nn


class ResidualCnn(nn.Module):
    """A plain residual CNN: 3 -> width -> ... -> 3 (3x3 convs, ReLU), output = input + residual."""

    def __init__(self, width, depth):
        super().__init__()
        layers = [nn.Conv2d(3, width, 3, padding=1), nn.ReLU()]
        for _ in range(depth - 2):
            layers += [nn.Conv2d(width, width, 3, padding=1), nn.ReLU()]
        layers += [nn.Conv2d(width, 3, 3, padding=1)]
        self.body = nn.Sequential(*layers)

    def forward(self, lq):
        return lq + self.body(lq)


class TinyUnet(nn.Module):
    """A two-scale U-Net (stride-2 conv down, transposed conv up, skip connection)."""

    def __init__(self, width):
        super().__init__()
        self.inc = nn.Sequential(nn.Conv2d(3, width, 3, padding=1), nn.ReLU(), nn.Conv2d(width, width, 3, padding=1), nn.ReLU())
        self.down = nn.Sequential(nn.Conv2d(width, 2 * width, 3, stride=2, padding=1), nn.ReLU(),
                                  nn.Conv2d(2 * width, 2 * width, 3, padding=1), nn.ReLU())
        self.up = nn.ConvTranspose2d(2 * width, width, 2, stride=2)
        self.out = nn.Sequential(nn.Conv2d(2 * width, width, 3, padding=1), nn.ReLU(), nn.Conv2d(width, 3, 3, padding=1))

    def forward(self, lq):
        a = self.inc(lq)
        b = self.up(self.down(a))
        return lq + self.out(torch.cat([a, b], 1))


def export(model, path):
    model.eval()
    example = torch.rand(1, 3, 64, 64)
    torch.onnx.export(model, (example,), str(path), input_names=["lq"], output_names=["restored"],
                      dynamic_axes={"lq": {0: "N", 2: "H", 3: "W"}, "restored": {0: "N", 2: "H", 3: "W"}},
                      opset_version=17, dynamo=False)
    import onnx
    m = onnx.load(str(path))
    for key, value in [("unicac_contract", "1"), ("architecture", path.stem), ("inputs", "lq")]:
        entry = m.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.save(m, str(path))


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("out", type=pathlib.Path)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--runs", type=int, default=20)
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    models = {"rescnn_w32_d8": ResidualCnn(32, 8), "unet_w24": TinyUnet(24)}
    x = torch.rand(1, 3, 256, 256)
    import onnxruntime as ort
    for name, model in models.items():
        path = args.out / f"{name}.onnx"
        export(model, path)
        with torch.inference_mode():
            for _ in range(3):
                reference = model(x)
            times = []
            for _ in range(args.runs):
                start = time.perf_counter()
                model(x)
                times.append(time.perf_counter() - start)
        options = ort.SessionOptions()
        options.intra_op_num_threads = args.threads
        session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
        restored = session.run(["restored"], {"lq": x.numpy()})[0]
        error = float(np.abs(restored - reference.numpy()).max())
        params = sum(p.numel() for p in model.parameters())
        median = sorted(times)[len(times) // 2]
        print(f"{name}: params {params}, torch median {median * 1e3:.1f} ms = {1 / median:.1f} images/s "
              f"(1x3x256x256, {args.threads} threads), onnxruntime vs torch max abs diff {error:.2e}")


if __name__ == "__main__":
    main()
