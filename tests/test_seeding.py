from refspatial.seeding import scene_seed, stable_int, stage_rng


def test_stable_int_is_fixed_across_runs_and_machines():
    # Golden value: a change here changes every dataset ever generated.
    assert stable_int("recipe", 1, "layout") == 0xFB6D18CE6773EE10
    assert stable_int("a", 1) == stable_int("a", 1)
    assert stable_int("a", 1) != stable_int("a", 2)
    assert stable_int("a", 12) != stable_int("a1", 2)  # parts are separated, not concatenated


def test_stages_draw_independently():
    a1 = stage_rng("h", 3, "layout").random(5)
    a2 = stage_rng("h", 3, "layout").random(5)
    b = stage_rng("h", 3, "light").random(5)
    assert (a1 == a2).all() and not (a1 == b).all()


def test_scene_seeds_are_positive_int64_and_distinct():
    seeds = [scene_seed(0, i) for i in range(1000)]
    assert len(set(seeds)) == 1000
    assert all(0 <= s < 2**62 for s in seeds)
    assert scene_seed(1, 0) not in seeds
