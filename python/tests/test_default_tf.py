"""The default transfer function ("auto", src/ugvr/render/default_transfer_function.h) is the same from Python as from
`ugvr render`: made from the field's histogram, the free stream transparent."""
import numpy as np

import ugvr

SIZE = (64, 48)


def cli_image(cli, tmp_path, inputs, *flags):
    out = tmp_path / "cli.png"
    cli("render", *inputs, "-o", out, "--size", f"{SIZE[0]}x{SIZE[1]}", *flags)
    return ugvr.read_image(out).array


def test_default_is_auto_and_the_cli_default(cli, tmp_path, small_vtu):
    ref = cli_image(cli, tmp_path, [small_vtu])
    # A file, and a dataset in memory (another path through the module).
    for source in (small_vtu, ugvr.read(small_vtu)):
        img = ugvr.render(source, size=SIZE)
        assert np.array_equal(img.array, ref)
        assert img.tf.name == "auto"
        # The generated pressure's free stream: a transparent stretch inside the range, opaque at both ends.
        opacities = [p[1] for p in img.tf.opacity_points]
        assert len(opacities) == 4 and opacities[1] == 0 and opacities[2] == 0 and opacities[0] == opacities[3] == 1
    # tf="auto" named is the default; "viridis" is the ramp, another image.
    assert np.array_equal(ugvr.render(small_vtu, size=SIZE, tf="auto").array, ref)
    ramp = ugvr.render(small_vtu, size=SIZE, tf="viridis")
    assert np.array_equal(ramp.array, cli_image(cli, tmp_path, [small_vtu], "--tf", "viridis"))
    assert not np.array_equal(ramp.array, ref)
    assert len(ramp.tf.opacity_points) == 2
