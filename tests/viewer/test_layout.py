from vismobile.viewer.layout import PANEL, layout, view_size, window_size


def test_device_screen_scaled_by_a_whole_number_beside_the_panel():
    size = window_size((240, 320), 2)
    panels = layout(size, (240, 320))
    assert panels.scale == 2 and panels.view == (0, size[1] - 640, 480, 640)
    assert panels.god[0] == 480 and panels.god[2] == PANEL
    bigger = layout((240 * 3 + PANEL + 50, 1200), (240, 320))
    assert bigger.scale == 3
    assert layout((100, 100), (240, 320)).scale == 1


def test_desktop_fills_the_left_part():
    panels = layout((640 + PANEL, 600), (640, 600), fill=True)
    assert panels.scale == 1 and panels.view == (0, 0, 640, 600)
    assert view_size((640 + PANEL, 600)) == (640, 600)
