"""scripts/install_python_path.sh: the .pth that makes `import plumage` work in /usr/bin/python3."""

import os
import pathlib
import subprocess

from conftest import SOURCE_DIR

SCRIPT = SOURCE_DIR / "scripts/install_python_path.sh"
MARKER = "# written by Plumage's scripts/install_python_path.sh: the build's python folder"


def build_dir(tmp_path) -> pathlib.Path:
    build = tmp_path / "build"
    (build / "python/plumage").mkdir(parents=True)
    return build


def install(build, site, user_site):
    env = dict(os.environ, PLUMAGE_SITE_DIR=str(site), PLUMAGE_USER_SITE_DIR=str(user_site))
    return subprocess.run([str(SCRIPT), str(build)], env=env, capture_output=True, text=True,
                          check=True)


def test_writes_then_replaces_only_its_own_file(tmp_path):
    build, site = build_dir(tmp_path), tmp_path / "site"
    install(build, site, tmp_path / "user")
    pth = site / "plumage.pth"
    assert pth.read_text() == f"{MARKER}\n{build / 'python'}\n"
    other = build_dir(tmp_path / "other")
    install(other, site, tmp_path / "user")  # the last checkout built wins
    assert pth.read_text().splitlines()[-1] == str(other / "python")
    assert [p.name for p in site.iterdir()] == ["plumage.pth"]  # no temporary left


def test_leaves_a_foreign_file_alone(tmp_path):
    build, site = build_dir(tmp_path), tmp_path / "site"
    site.mkdir()
    (site / "plumage.pth").write_text("/somewhere/else\n")
    run = install(build, site, tmp_path / "user")
    assert (site / "plumage.pth").read_text() == "/somewhere/else\n"
    assert "not written by Plumage; left as it is" in run.stderr


def test_user_site_when_the_site_folder_is_not_writable(tmp_path):
    if os.geteuid() == 0:
        site = pathlib.Path("/proc/plumage-not-writable")  # not even root writes there
    else:
        site = tmp_path / "site"
        site.mkdir(mode=0o555)
    build, user = build_dir(tmp_path), tmp_path / "user"
    install(build, site, user)
    assert (user / "plumage.pth").read_text().splitlines()[-1] == str(build / "python")
