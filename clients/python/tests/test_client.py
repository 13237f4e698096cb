"""wedge_client against a real server, whose address is in WEDGE_ADDR (tests/python_client.rs
starts one and runs these). Values are checked, not only shapes: progressive frames gain
samples, a scene file renders exactly as the built-in it was written from, a session's moved
view equals a fresh render of that view, refused changes name their field."""
import os
import subprocess
import sys
import tempfile
import unittest

import numpy as np

import wedge_client
from wedge_client import pb

ADDR = os.environ.get("WEDGE_ADDR", "127.0.0.1:50051")
REPO = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "..")
SMALL = dict(width=32, height=24, method="uniform", seed=3, bounces=1)


class RenderTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.client = wedge_client.Client(ADDR)

    def test_frames_are_numpy_layers_that_refine(self):
        frames = list(self.client.render_frames("cornell", max_passes=3, **SMALL))
        self.assertEqual(len(frames), 3)
        last = frames[-1]
        self.assertTrue(last.is_final)
        self.assertEqual(last.color.shape, (24, 32, 3))
        self.assertEqual(last.color.dtype, np.float32)
        self.assertEqual(last.spp.shape, (24, 32))
        self.assertTrue(np.isfinite(last.color).all())
        spp = [float(f.spp.mean()) for f in frames]
        self.assertEqual(spp, sorted(spp))
        self.assertLess(spp[0], spp[-1])
        self.assertAlmostEqual(spp[-1], last.mean_spp, places=3)
        self.assertGreater(last.color.mean(), 0.01)
        self.assertEqual([f.pass_index for f in frames], [0, 1, 2])

    def test_f16_frames_equal_f32_frames_to_half_precision(self):
        a = self.client.render("cornell", max_passes=2, **SMALL)
        b = self.client.render("cornell", max_passes=2, f16=True, **SMALL)
        np.testing.assert_allclose(b.color, a.color, rtol=1e-3, atol=1e-4)

    def test_a_scene_file_renders_as_the_built_in_it_was_written_from(self):
        path = os.path.join(REPO, "scenes", "cornell.json")
        by_file = self.client.render(path, max_passes=2, **SMALL)
        builtin = self.client.render("cornell", max_passes=2, **SMALL)
        np.testing.assert_array_equal(by_file.color, builtin.color)
        digest = self.client.put_scene(path)
        self.assertRegex(digest, r"^sha256:[0-9a-f]{64}$")

    def test_bad_arguments_are_named(self):
        with self.assertRaisesRegex(ValueError, "method 'nope'"):
            self.client.request("cornell", method="nope")
        with self.assertRaisesRegex(ValueError, "camera: unknown keys"):
            self.client.request("cornell", camera={"eye": (0, 0, 0)})
        import grpc

        with self.assertRaises(grpc.RpcError) as caught:
            self.client.render("cornell", width=1 << 20, height=1 << 20, max_passes=1)
        self.assertEqual(caught.exception.code(), grpc.StatusCode.INVALID_ARGUMENT)
        self.assertIn("width", caught.exception.details())


class SessionTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.client = wedge_client.Client(ADDR)

    def test_an_orbit_renders_the_new_view_exactly_as_a_fresh_render(self):
        with self.client.session("cornell", max_passes=2, **SMALL) as s:
            first = s.next_frame(final=True)
            self.assertEqual(first.generation, 1)
            camera = s.camera()
            self.assertAlmostEqual(camera.position.z, -800.0, places=3)
            generation = s.orbit(yaw_deg=20, pitch_deg=5, zoom=0.9)
            self.assertEqual(generation, 2)
            moved = s.next_frame(generation=generation, final=True)
            self.assertEqual(moved.generation, 2)
            self.assertGreater(np.abs(moved.color - first.color).mean(), 1e-3)
            c = s.camera()
            view = {"position": (c.position.x, c.position.y, c.position.z), "look_at": (c.look_at.x, c.look_at.y, c.look_at.z), "up": (c.up.x, c.up.y, c.up.z)}
            fresh = self.client.render("cornell", max_passes=2, camera=view, **SMALL)
            np.testing.assert_array_equal(moved.color, fresh.color)
            # The distance shrank by the zoom.
            before = np.linalg.norm([camera.position.x - camera.look_at.x, camera.position.y - camera.look_at.y, camera.position.z - camera.look_at.z])
            after = np.linalg.norm(np.subtract(view["position"], view["look_at"]))
            self.assertAlmostEqual(after / before, 0.9, places=4)

    def test_a_refused_change_names_its_field_and_the_session_goes_on(self):
        with self.client.session("cornell", max_passes=1, **SMALL) as s:
            s.next_frame(final=True)
            with self.assertRaises(wedge_client.SessionError) as caught:
                s.update(width=1 << 20)
            self.assertEqual(caught.exception.field, "width")
            bad_material = pb.Material(name="no-such-material")
            bad_material.lambertian.albedo.constant.r = 0.5
            with self.assertRaises(wedge_client.SessionError) as caught:
                s.update(materials=[bad_material])
            self.assertEqual(caught.exception.field, "edit.materials[0].name")
            generation = s.update(method="aaf")
            self.assertEqual(generation, 2)
            self.assertEqual(s.next_frame(generation=generation, final=True).generation, 2)


class ExampleTest(unittest.TestCase):
    def test_the_interactive_example_follows_piped_commands(self):
        example = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "examples", "orbit.py")
        with tempfile.TemporaryDirectory() as tmp:
            png = os.path.join(tmp, "view.png")
            commands = f"d\nw\n+\nm uniform\nx\np {png}\nq\n"
            run = subprocess.run(
                [sys.executable, example, "--server", ADDR, "--size", "32x24", "--passes", "2"],
                input=commands, capture_output=True, text=True, timeout=120,
            )
            self.assertEqual(run.returncode, 0, run.stderr)
            lines = run.stdout.splitlines()
            generations = [int(l.split()[1]) for l in lines if l.startswith("generation")]
            self.assertEqual(generations, [1, 2, 3, 4, 5], run.stdout)
            self.assertIn("unknown command 'x' (a d w s + - m p q)", lines)
            self.assertIn(f"saved {png}", lines)
            with open(png, "rb") as f:
                data = f.read()
            self.assertEqual(data[:8], b"\x89PNG\r\n\x1a\n")
            self.assertEqual(int.from_bytes(data[16:20], "big"), 32)


if __name__ == "__main__":
    unittest.main()
